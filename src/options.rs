//! The LED detector's command-line options, shared by `glint track` (and `glint run`, whose
//! settings file has the same keys) and by the tools that replay a dump exactly as
//! `glint track` would (`glint-view`): one parser and one mapping to [`DetectorConfig`], so the
//! two cannot drift apart.

use clap::{Args, ValueEnum};

use crate::detect::morph::Kernel;
use crate::detect::skeleton::SkeletonMethod;
use crate::detect::streak::StreakModel;
use crate::detect::threshold::Threshold;
use crate::detect::{DetectorConfig, MaskMethod};

/// The frame rates accepted: from one frame in 10 s (a time-lapse) to far above any webcam.
/// The lower bound also keeps frame times (`index / fps`) far from overflowing.
pub const MIN_FPS: f64 = 0.1;
pub const MAX_FPS: f64 = 1_000.0;

/// Most erosions: each costs a pass over the mask, and 32 erase any LED a webcam shows.
pub const MAX_EROSIONS: u32 = 32;

/// Longest stretch of a value quoted back in a message.
const MAX_QUOTED_CHARS: usize = 80;

/// How the LED is cut out of a frame and thinned.
#[derive(Debug, Clone, Args)]
pub struct LedArgs {
    /// Saturation threshold (luma 0–255), or `auto` to follow each frame's top level.
    #[arg(long, default_value = "auto", value_parser = parse_threshold,
          allow_negative_numbers = true)]
    pub threshold: Threshold,

    /// Erosions of the mask before blobs are found, 0 to 32 (the seed used 10, which erases
    /// LEDs narrower than 21 px).
    #[arg(long, default_value_t = 0, value_name = "N", allow_negative_numbers = true,
          value_parser = clap::value_parser!(u32).range(0..=MAX_EROSIONS as i64))]
    pub erode: u32,

    /// Structuring element of the erosions.
    #[arg(long, value_enum, default_value_t = KernelArg::Square)]
    pub erode_kernel: KernelArg,

    /// Skeleton for the streak's middle and ends.
    #[arg(long, value_enum, default_value_t = SkeletonArg::Thinning)]
    pub skeleton: SkeletonArg,

    /// How the LED's positions at the start and end of the exposure are measured.
    // The library's default (`StreakModel::default`), which a test holds it to.
    #[arg(long, value_enum, default_value_t = StreakModelArg::Auto)]
    pub streak_model: StreakModelArg,
}

/// `--streak-model`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum StreakModelArg {
    /// Brightness ramps at the ends, for a sharp-edged disk spot.
    Ramps,
    /// A swept-spot model fitted to the pixels (spot width, brightness, gamma from the frame).
    Fit,
    /// The ramps, and the fit where the spot's edge is not sharp (a Gaussian, a glow).
    Auto,
}

/// `--erode-kernel`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum KernelArg {
    Square,
    Cross,
}

/// `--skeleton`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum SkeletonArg {
    /// Guo–Hall thinning: connected and one pixel wide.
    Thinning,
    /// The seed's morphological skeleton.
    Seed,
}

impl LedArgs {
    /// The detector these options describe, finding the LED by `method`.
    pub fn detector_config(&self, method: MaskMethod) -> DetectorConfig {
        DetectorConfig {
            method,
            threshold: self.threshold,
            erosions: self.erode,
            erosion_kernel: match self.erode_kernel {
                KernelArg::Square => Kernel::Square,
                KernelArg::Cross => Kernel::Cross,
            },
            skeleton: match self.skeleton {
                SkeletonArg::Thinning => SkeletonMethod::Thinning,
                SkeletonArg::Seed => SkeletonMethod::Morphological,
            },
            streak_model: match self.streak_model {
                StreakModelArg::Ramps => StreakModel::Ramps,
                StreakModelArg::Fit => StreakModel::Fit,
                StreakModelArg::Auto => StreakModel::Auto,
            },
            ..DetectorConfig::default()
        }
    }
}

/// Parses `--fps`: from [`MIN_FPS`] to [`MAX_FPS`] frames per second. The message does not
/// repeat the value: clap's line already shows it, with the option.
pub fn parse_fps(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(f) if (MIN_FPS..=MAX_FPS).contains(&f) => Ok(f),
        _ => Err(format!(
            "a frame rate is {MIN_FPS} to {MAX_FPS} frames per second"
        )),
    }
}

/// Longest row time taken, µs: 480 such rows take half a second to read.
const MAX_ROW_TIME_US: f32 = 1000.0;

/// Parses `--row-time-us`: above 0, up to 1000 µs.
pub fn parse_row_time_us(s: &str) -> Result<f32, String> {
    match s.parse::<f32>() {
        Ok(v) if v.is_finite() && v > 0.0 && v <= MAX_ROW_TIME_US => Ok(v),
        _ => Err(format!(
            "not a row time above 0 and up to {MAX_ROW_TIME_US} µs"
        )),
    }
}

/// Parses `--threshold`: `auto` or a luma level.
pub fn parse_threshold(s: &str) -> Result<Threshold, String> {
    if s == "auto" {
        return Ok(Threshold::Auto);
    }
    s.parse::<u8>()
        .map(Threshold::Fixed)
        .map_err(|_| "neither `auto` nor a luma level 0–255".to_string())
}

/// `value` as it may be quoted back in a message: whole when short, else its first 80
/// characters and an ellipsis, so that a 10 MB value does not come back as a 10 MB line.
pub fn shortened(value: &str) -> String {
    match value.char_indices().nth(MAX_QUOTED_CHARS) {
        Some((cut, _)) => format!("{}…", &value[..cut]),
        None => value.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values_parse_or_say_why_not() {
        assert_eq!(parse_threshold("auto"), Ok(Threshold::Auto));
        assert_eq!(parse_threshold("240"), Ok(Threshold::Fixed(240)));
        assert!(parse_threshold("256").unwrap_err().contains("neither"));
        assert_eq!(parse_fps("29.97"), Ok(29.97));
        assert_eq!(parse_fps("0.1"), Ok(0.1));
        for bad in ["0", "-1", "0.09", "1e-300", "nan", "inf", "1001", "fast"] {
            let e = parse_fps(bad).unwrap_err();
            assert_eq!(e, "a frame rate is 0.1 to 1000 frames per second", "{bad}");
        }
    }

    #[test]
    fn long_values_are_shortened_on_a_character_boundary() {
        assert_eq!(shortened("640x480"), "640x480");
        let long = "é".repeat(10_000);
        let short = shortened(&long);
        assert_eq!(short.chars().count(), 81);
        assert!(short.ends_with('…'));
        assert_eq!(shortened(&"a".repeat(80)), "a".repeat(80));
    }

    #[test]
    fn the_options_map_onto_the_detector() {
        let args = LedArgs {
            threshold: Threshold::Fixed(200),
            erode: 10,
            erode_kernel: KernelArg::Cross,
            skeleton: SkeletonArg::Seed,
            streak_model: StreakModelArg::Fit,
        };
        let config = args.detector_config(MaskMethod::Saturation);
        assert_eq!(config.threshold, Threshold::Fixed(200));
        assert_eq!(config.erosions, 10);
        assert_eq!(config.erosion_kernel, Kernel::Cross);
        assert_eq!(config.skeleton, SkeletonMethod::Morphological);
        assert_eq!(config.streak_model, StreakModel::Fit);
        assert_eq!(config.min_area_px, DetectorConfig::default().min_area_px);
        let auto = LedArgs {
            streak_model: StreakModelArg::Auto,
            ..args
        };
        let config = auto.detector_config(MaskMethod::Saturation);
        assert_eq!(config.streak_model, StreakModel::Auto);
    }

    /// `glint track` without `--streak-model` measures the streak as the library does by
    /// default, so a replay through the library and one through the binary agree.
    #[test]
    fn the_option_s_default_is_the_library_s() {
        #[derive(clap::Parser)]
        struct Cli {
            #[command(flatten)]
            led: LedArgs,
        }
        let cli = <Cli as clap::Parser>::try_parse_from(["glint"]).unwrap();
        let config = cli.led.detector_config(MaskMethod::Saturation);
        assert_eq!(config.streak_model, DetectorConfig::default().streak_model);
        assert_eq!(config.streak_model, StreakModel::Auto);
    }
}
