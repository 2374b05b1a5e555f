//! Frame buffers handed back for reuse. A clip's frames are all the same size, so the decode
//! thread can write each new frame into the buffer of one the tracker has finished with instead
//! of into freshly allocated memory, which the kernel would have to map (and zero) again.

use std::sync::{Arc, Mutex};

/// Most buffers kept waiting; more handed back are freed. Enough for the frames in flight
/// between the decode thread and the tracker (a channel of 8, each with its working image).
const KEPT: usize = 24;

/// A shared stock of spare byte buffers (cloning shares it).
#[derive(Debug, Clone, Default)]
pub struct Recycler(Arc<Mutex<Vec<Vec<u8>>>>);

impl Recycler {
    pub fn new() -> Recycler {
        Recycler::default()
    }

    /// An empty buffer with room for at least `len` bytes: the smallest spare one large
    /// enough (so that large buffers stay for large frames), else a new one.
    pub fn take(&self, len: usize) -> Vec<u8> {
        let mut spare = self.0.lock().unwrap_or_else(|e| e.into_inner());
        let fits = (0..spare.len())
            .filter(|&i| spare[i].capacity() >= len)
            .min_by_key(|&i| spare[i].capacity());
        match fits {
            Some(i) => {
                let mut b = spare.swap_remove(i);
                b.clear();
                b
            }
            None => Vec::with_capacity(len),
        }
    }

    /// Hands `buf` back for a later [`Recycler::take`] (freed when [`KEPT`] are waiting).
    pub fn give(&self, buf: Vec<u8>) {
        let mut spare = self.0.lock().unwrap_or_else(|e| e.into_inner());
        if spare.len() < KEPT && buf.capacity() > 0 {
            spare.push(buf);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_buffer_handed_back_is_the_one_taken_next() {
        let r = Recycler::new();
        let mut b = r.take(100);
        assert!(b.capacity() >= 100 && b.is_empty());
        b.extend_from_slice(&[7; 100]);
        let at = b.as_ptr();
        r.clone().give(b);
        // Too small for 1000 bytes: a new one.
        let big = r.take(1000);
        assert_ne!(big.as_ptr(), at);
        // Large enough for 50: the spare one, emptied; of two that fit, the smaller.
        r.give(big);
        let again = r.take(50);
        assert_eq!((again.as_ptr(), again.len()), (at, 0));
        for _ in 0..2 * KEPT {
            r.give(vec![0; 8]);
        }
        assert_eq!(r.0.lock().unwrap().len(), KEPT);
    }
}
