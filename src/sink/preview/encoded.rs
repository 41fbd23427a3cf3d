//! The copied frame as an image, shared by every viewer.
//!
//! A request for the frame gets an `Arc` of the encoded image, not a copy: viewers asking for
//! the same copied frame while any of them is still being sent it share one image. At most
//! [`LIVE_IMAGES`] images exist at once: when that many are still held by viewers (slow ones,
//! say) and the sink has copied a newer frame, a new viewer is sent the newest image there is
//! rather than a fresh encoding. So the memory the images take is bounded by
//! `LIVE_IMAGES × bmp::file_bytes`, whatever the number of viewers, and the cache holds only
//! weak references: once the last viewer has been sent an image, it is freed. Each image is an
//! anonymous memory mapping of its own, so freeing it gives the memory back to the system
//! (malloc would keep an image under 32 MB in the arena of whichever thread made it, one per
//! connection thread over time).

use std::io;
use std::sync::{Arc, Mutex, PoisonError, Weak};

use heapless::Vec as BoundedVec;
use memmap2::MmapMut;

use super::{bmp, Snapshot};

/// Encoded images alive at once, at most (one being sent to slow viewers, one for the rest).
pub const LIVE_IMAGES: usize = 2;

/// One encoded image and the copy it shows.
#[derive(Debug)]
struct Image {
    /// [`super::Seen::copies`] when it was encoded.
    copies: u64,
    bmp: Weak<MmapMut>,
}

/// The images viewers are being sent, oldest first.
#[derive(Debug, Default)]
pub struct Encoded {
    images: Mutex<BoundedVec<Image, LIVE_IMAGES>>,
}

impl Encoded {
    pub fn new() -> Self {
        Encoded::default()
    }

    /// The image of the last copied frame, encoded now if no viewer holds it and fewer than
    /// [`LIVE_IMAGES`] images are alive; else the newest alive one. Encodings are serialised:
    /// viewers arriving while one is made wait for it and share it. Fails only when the
    /// system has no memory for a new image.
    pub fn frame(&self, snapshot: &Mutex<Snapshot>) -> io::Result<Arc<MmapMut>> {
        let mut images = self.images.lock().unwrap_or_else(PoisonError::into_inner);
        // Strong references while deciding, so none is freed in between.
        let mut alive: BoundedVec<(u64, Arc<MmapMut>), LIVE_IMAGES> = BoundedVec::new();
        for image in images.iter() {
            if let Some(bmp) = image.bmp.upgrade() {
                // At most as many as `images` holds.
                let _ = alive.push((image.copies, bmp));
            }
        }
        images.retain(|image| image.bmp.strong_count() > 0);
        let copies = snapshot
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .seen
            .copies;
        if let Some((newest_copies, newest)) = alive.last() {
            if *newest_copies == copies || alive.is_full() {
                return Ok(Arc::clone(newest));
            }
        }
        let (copies, bmp) = encode(snapshot)?;
        // Never full here: `images` holds exactly the alive ones, and they are not all.
        let _ = images.push(Image {
            copies,
            bmp: Arc::downgrade(&bmp),
        });
        Ok(bmp)
    }
}

/// Encodes the snapshot: the mapping is made before its lock is taken, so the sink's
/// `try_lock` fails only while the pixels are read.
fn encode(snapshot: &Mutex<Snapshot>) -> io::Result<(u64, Arc<MmapMut>)> {
    let size = snapshot
        .lock()
        .unwrap_or_else(PoisonError::into_inner)
        .seen
        .size;
    let mut out = MmapMut::map_anon(bmp::file_bytes(size))?;
    let snapshot = snapshot.lock().unwrap_or_else(PoisonError::into_inner);
    bmp::encode(&snapshot, &mut out);
    Ok((snapshot.seen.copies, Arc::new(out)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::FrameSize;

    fn snapshot() -> Mutex<Snapshot> {
        Mutex::new(Snapshot::new(FrameSize::new(4, 2).unwrap()))
    }

    fn next_copy(snapshot: &Mutex<Snapshot>) {
        snapshot.lock().unwrap().seen.copies += 1;
    }

    #[test]
    fn viewers_of_one_copy_share_one_image() {
        let (encoded, snapshot) = (Encoded::new(), snapshot());
        let a = encoded.frame(&snapshot).unwrap();
        let b = encoded.frame(&snapshot).unwrap();
        assert!(Arc::ptr_eq(&a, &b));
        assert_eq!(&a[..2], b"BM");
        // A newer copy is encoded anew while the old image is still held.
        next_copy(&snapshot);
        let c = encoded.frame(&snapshot).unwrap();
        assert!(!Arc::ptr_eq(&a, &c));
    }

    #[test]
    fn at_most_live_images_exist_and_freed_ones_make_room() {
        let (encoded, snapshot) = (Encoded::new(), snapshot());
        let held: Vec<_> = (0..LIVE_IMAGES)
            .map(|_| {
                next_copy(&snapshot);
                encoded.frame(&snapshot).unwrap()
            })
            .collect();
        // Full: a newer copy gets the newest alive image, not a new one.
        next_copy(&snapshot);
        let stale = encoded.frame(&snapshot).unwrap();
        assert!(Arc::ptr_eq(&stale, held.last().unwrap()));
        drop(stale);
        // The oldest viewer is done: its image is freed and the newer copy is encoded.
        let oldest = Arc::downgrade(&held[0]);
        drop(held);
        assert_eq!(oldest.strong_count(), 0);
        let fresh = encoded.frame(&snapshot).unwrap();
        assert_eq!(encoded.images.lock().unwrap().last().unwrap().copies, {
            snapshot.lock().unwrap().seen.copies
        });
        assert_eq!(
            Arc::strong_count(&fresh),
            1,
            "the cache holds no strong reference"
        );
    }
}
