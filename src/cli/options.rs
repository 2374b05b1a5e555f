//! The one step from flags to the library's options: every command's flags become its options
//! here, and nowhere else (tracking parameters are read and validated by
//! [`mocap2d::app::read_params`]).

use super::args::*;
use mocap2d::app;
use mocap2d::background::BackgroundChoice;
use mocap2d::Result;
use std::path::PathBuf;

impl BatchArgs {
    /// The options of `batch`.
    pub fn options(&self) -> Result<mocap2d::batch::BatchOptions> {
        Ok(mocap2d::batch::BatchOptions {
            inputs: self.inputs.clone(),
            seeds: mocap2d::batch::SeedTemplate::parse(&self.seeds)?,
            jobs: self.jobs.map_or_else(
                || std::thread::available_parallelism().map_or(1, |n| n.get()),
                usize::from,
            ),
            shard: self.shard,
            out_dir: self.out_dir.clone(),
            fps: self.fps,
            no_background: self.no_background,
            params: app::read_params(self.params.as_deref())?,
            retarget: self.retarget.clone(),
            render: self.render,
        })
    }

    /// The summary CSV's path (see `--summary`).
    pub fn summary_path(&self) -> PathBuf {
        if let Some(p) = &self.summary {
            return p.clone();
        }
        let name = match self.shard {
            Some(s) => format!("batch-summary-{}of{}.csv", s.index, s.count),
            None => "batch-summary.csv".into(),
        };
        match &self.out_dir {
            Some(d) => d.join(name),
            None => PathBuf::from(name),
        }
    }
}

impl TrackArgs {
    /// The options of `track`, and what to do with a run folder holding another clip's run.
    pub fn options(self) -> Result<(app::TrackOptions, app::OtherClip)> {
        let (seeds, dlc) = self.seed_source();
        let other = match self.replace {
            true => app::OtherClip::Replace,
            false => app::OtherClip::Refuse,
        };
        let mut params = app::read_params(self.params.as_deref())?;
        params.pose = match self.pose.as_deref() {
            Some("on") => mocap2d::track::PoseMode::On,
            Some("off") => mocap2d::track::PoseMode::Off,
            Some(_) => mocap2d::track::PoseMode::Auto,
            None => params.pose,
        };
        let opts = app::TrackOptions {
            params,
            clip: self.clip,
            seeds,
            dlc,
            out: self.out,
            fps: self.fps,
            background: BackgroundChoice::from_flags(self.background, self.no_background),
            segment_len: self.segment_len,
        };
        Ok((opts, other))
    }

    /// The seed file (or DeepLabCut CSV) and, for a CSV, how to read it.
    pub fn seed_source(&self) -> (PathBuf, Option<mocap2d::seed::dlc::DlcSeedOptions>) {
        match (&self.seeds, &self.seeds_from_dlc) {
            (_, Some(csv)) => (
                csv.clone(),
                Some(mocap2d::seed::dlc::DlcSeedOptions {
                    frame: self.seed_frame.unwrap_or(0),
                    size: self.seed_size,
                    skeleton: self.skeleton.clone(),
                }),
            ),
            (Some(s), None) => (s.clone(), None),
            (None, None) => unreachable!("clap requires --seeds or --seeds-from-dlc"),
        }
    }
}

impl SeedArgs {
    /// The options of `seed`.
    pub fn options(self) -> Result<app::SeedOptions> {
        let within = match self.within {
            None => None,
            Some(v) if v.len() == 4 && v[2] > 0.0 && v[3] > 0.0 => Some([v[0], v[1], v[2], v[3]]),
            Some(_) => return Err(mocap2d::Error::Usage(
                "--box takes x,y,w,h with a positive width and height, e.g. --box 100,50,200,400"
                    .into(),
            )),
        };
        Ok(app::SeedOptions {
            clip: self.clip,
            frame: self.frame,
            out: self.out,
            within,
            fps: self.fps,
        })
    }
}

impl ResumeArgs {
    /// The options of `resume`.
    pub fn options(self) -> Result<app::ResumeOptions> {
        Ok(app::ResumeOptions {
            params: match &self.params {
                Some(p) => Some(app::read_params(Some(p))?),
                None => None,
            },
            run: self.run,
            segment: self.segment,
            clip: self.clip,
        })
    }
}

impl SynthArgs {
    /// The options of `synth`.
    pub fn options(&self) -> mocap2d::synth::SynthOptions {
        mocap2d::synth::SynthOptions {
            scenario: self.scenario,
            width: self.size.0,
            height: self.size.1,
            seed: self.seed,
            frames: self.frames,
        }
    }
}

impl RetargetArgs {
    /// The retargeting options these flags ask for.
    pub fn options(&self) -> mocap2d::retarget::RetargetOptions {
        mocap2d::retarget::RetargetOptions {
            smooth: self.smooth,
            cartoon: self.cartoon.map(|strength| mocap2d::retarget::Cartoon {
                strength,
                sigma_frames: self.cartoon_sigma,
            }),
            keep_size: self.keep_size,
            clean: mocap2d::retarget::cleanup::Cleanup {
                strength: self.clean,
            },
            stretch: self.stretch,
            plant_feet: !self.no_plant,
        }
    }
}

impl RenderArgs {
    /// The options of `render`.
    pub fn options(self) -> app::RenderOptions {
        app::RenderOptions {
            run: self.run,
            target: self.target,
            out: self.out,
            frames_dir: self.frames_dir,
            deform: mocap2d::deform::DeformOptions {
                area_preservation: !self.no_area_preservation,
                stage_two: true,
            },
        }
    }
}

impl ExportArgs {
    /// The options of `export`.
    pub fn options(self) -> app::ExportOptions {
        let keys = self.keys();
        app::ExportOptions {
            run: self.run,
            format: self.format,
            target: self.target,
            out: self.out,
            keys,
            skeleton: self.skeleton.map(|path| app::UserSkeleton {
                path,
                animation: self.animation,
                bones: self.bone,
                bone_map: self.bone_map,
                keep_ik: self.keep_ik,
            }),
        }
    }

    /// How the skeleton formats key their channels.
    pub fn keys(&self) -> mocap2d::export::keys::Keys {
        if self.every_frame {
            mocap2d::export::keys::Keys::EveryFrame
        } else {
            mocap2d::export::keys::Keys::Reduce {
                tolerance: self.tolerance,
                curves: !self.linear,
            }
        }
    }
}

impl GuideArgs {
    /// The options of `guide`.
    pub fn options(self) -> app::GuideOptions {
        app::GuideOptions {
            clip: self.clip,
            frame: self.frame,
            out: self.out,
            seeds_out: self.seeds_out,
            fps: self.fps,
            background: self.background,
        }
    }
}
