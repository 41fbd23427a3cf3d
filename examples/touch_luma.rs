//! The baseline for replay speed: read a raw YUYV dump frame by frame and touch every luma
//! byte (sum them), doing nothing else. `glint track` on the same dump is compared with it.
//!
//! `cargo run --release --example touch_luma -- DUMP WIDTHxHEIGHT`

use std::fs::File;
use std::io::Read;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let path = args.next().ok_or("usage: touch_luma DUMP WxH")?;
    let size: glint::frame::FrameSize = args.next().ok_or("usage: touch_luma DUMP WxH")?.parse()?;
    let mut file = File::open(path)?;
    let mut buffer = vec![0u8; size.frame_bytes()];
    let (mut frames, mut sum) = (0u64, 0u64);
    while file.read_exact(&mut buffer).is_ok() {
        // Per frame the sum fits a u32 (at most 16 384² pixels of 255 would not, but dumps this
        // baseline is run on do); u32 lanes let the compiler vectorise the loop.
        sum += u64::from(buffer.chunks_exact(2).map(|p| u32::from(p[0])).sum::<u32>());
        frames += 1;
    }
    println!("{frames} frames, luma sum {sum}");
    Ok(())
}
