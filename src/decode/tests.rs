use super::*;

fn frame(value: u8) -> RgbImage {
    RgbImage::from_pixel(4, 3, image::Rgb([value, 0, 0]))
}

#[test]
fn spread_indices_centre_slices() {
    assert_eq!(spread_indices(10, 5), vec![1, 3, 5, 7, 9]);
    assert_eq!(spread_indices(10, 2), vec![2, 7]);
    assert_eq!(spread_indices(3, 5), vec![0, 1, 2]);
    assert_eq!(spread_indices(100, 1), vec![50]);
    assert!(spread_indices(5, 0).is_empty());
}

#[test]
fn reader_yields_all_frames_in_order_then_closes() {
    let frames: Vec<_> = (0..20).map(frame).collect();
    let rx = spawn_reader(Box::new(MemorySource::new(frames, 25.0)), 2);
    let got: Vec<_> = rx.iter().map(|r| r.unwrap()).collect();
    assert_eq!(got.len(), 20);
    for (i, (index, img)) in got.iter().enumerate() {
        assert_eq!(*index, i as u64);
        assert_eq!(img.get_pixel(0, 0)[0], i as u8);
    }
}

#[test]
fn reader_stops_when_receiver_dropped() {
    struct Endless(ClipInfo, std::sync::Arc<std::sync::atomic::AtomicU64>);
    impl FrameSource for Endless {
        fn info(&self) -> &ClipInfo {
            &self.0
        }
        fn next_frame(&mut self) -> Result<Option<RgbImage>> {
            self.1.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
            Ok(Some(RgbImage::new(2, 2)))
        }
    }
    let count = std::sync::Arc::new(std::sync::atomic::AtomicU64::new(0));
    let info = ClipInfo {
        path: "endless".into(),
        width: 2,
        height: 2,
        fps: 30.0,
        frame_count_hint: None,
        stated_frames: None,
    };
    let rx = spawn_reader(Box::new(Endless(info, count.clone())), 1);
    assert_eq!(rx.recv().unwrap().unwrap().0, 0);
    drop(rx);
    std::thread::sleep(std::time::Duration::from_millis(50));
    let after_drop = count.load(std::sync::atomic::Ordering::SeqCst);
    std::thread::sleep(std::time::Duration::from_millis(50));
    assert_eq!(count.load(std::sync::atomic::Ordering::SeqCst), after_drop);
    assert!(
        after_drop <= 4,
        "{after_drop} frames decoded after the receiver was dropped"
    );
}

#[test]
fn reader_sends_error_last() {
    struct Failing(ClipInfo, u64);
    impl FrameSource for Failing {
        fn info(&self) -> &ClipInfo {
            &self.0
        }
        fn next_frame(&mut self) -> Result<Option<RgbImage>> {
            self.1 += 1;
            if self.1 > 3 {
                return Err(Error::Decode {
                    path: "x".into(),
                    frame: 3,
                    msg: "bad".into(),
                });
            }
            Ok(Some(RgbImage::new(2, 2)))
        }
    }
    let info = ClipInfo {
        path: "x".into(),
        width: 2,
        height: 2,
        fps: 30.0,
        frame_count_hint: None,
        stated_frames: None,
    };
    let items: Vec<_> = spawn_reader(Box::new(Failing(info, 0)), 0).iter().collect();
    assert_eq!(items.len(), 4);
    assert!(items[..3].iter().all(|r| r.is_ok()));
    assert!(matches!(items[3], Err(Error::Decode { frame: 3, .. })));
}

#[test]
fn salvage_keeps_frames_before_damage_and_records_where() {
    let decode_err = |frame| {
        Err(Error::Decode {
            path: "x".into(),
            frame,
            msg: "bad packet".into(),
        })
    };
    let ok = |i| Ok((i, RgbImage::new(2, 2)));
    // Damage after 3 frames: those 3, then the stop at frame 3 with the decoder's reason.
    let mut stop = None;
    let items = vec![ok(0), ok(1), ok(2), decode_err(3), ok(4)];
    let got: Vec<_> = salvage(items.into_iter(), Some(10), &mut stop).collect();
    assert_eq!(got.len(), 3);
    assert!(got.iter().all(|r| r.is_ok()));
    let stop = stop.unwrap();
    assert_eq!((stop.frame, stop.stated_frames), (3, Some(10)));
    assert_eq!(stop.reason, "bad packet");
    assert!(stop
        .to_string()
        .contains("decoding stopped at frame 3 of the 10"));
    // Damage on the first frame is an error, not an empty clip.
    let mut stop = None;
    let got: Vec<_> = salvage(vec![decode_err(0)].into_iter(), None, &mut stop).collect();
    assert!(matches!(got[..], [Err(Error::Decode { .. })]));
    assert!(stop.is_none());
    // Ending early against the stated count is recorded; ending on it is not.
    let mut stop = None;
    let _ = salvage(vec![ok(0), ok(1)].into_iter(), Some(5), &mut stop).count();
    assert_eq!(stop.map(|s| s.frame), Some(2));
    let mut stop = None;
    let _ = salvage(vec![ok(0), ok(1)].into_iter(), Some(2), &mut stop).count();
    assert!(stop.is_none());
}

#[test]
fn missing_path_is_a_clip_error_naming_it() {
    let err = open(Path::new("/no/such/clip.mp4"), None).err().unwrap();
    assert!(matches!(err, Error::Clip { .. }));
    assert!(err.is_user_error());
    let msg = err.to_string();
    assert!(
        msg.contains("/no/such/clip.mp4") && msg.contains("no such file"),
        "{msg}"
    );
    let err = sample_frames(Path::new("/no/such/clip.mp4"), 4)
        .err()
        .unwrap();
    assert!(matches!(err, Error::Clip { .. }));
}

#[test]
fn bad_fps_is_a_usage_error() {
    let dir = tempfile::tempdir().unwrap();
    for fps in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        assert!(matches!(open(dir.path(), Some(fps)), Err(Error::Usage(_))));
    }
}
