//! The key expressions one camera publishes under, built and checked once at start-up.
//!
//! With `--publish KEY` and `--camera-name CAM`:
//!
//! | key expression | payload | encoding |
//! |---|---|---|
//! | `KEY/CAM` | glint's JSON line, plus `camera` and `unix_us` | `application/json` |
//! | `KEY/CAM/bin` | the compact binary form ([`super::wire`]) | `application/octet-stream;glint.report.1` |
//! | `KEY/CAM/point` | `geometry_msgs/msg/PointStamped`, CDR ([`super::ros`]), for zenoh-bridge-ros2dds | `application/cdr` |
//! | `D/KEY/CAM/point/geometry_msgs::msg::dds_::PointStamped_/RIHS01_…` | the same, with rmw_zenoh's attachment | `application/cdr` |
//!
//! `D` is the ROS domain id. A subscriber on `KEY/*` gets every camera's JSON lines and
//! nothing else but `KEY/fused` ([`FUSED_CHUNK`], what `glint fuse --publish KEY` publishes);
//! `KEY/**` gets everything. The ROS topic is `/KEY/CAM/point`, with every
//! character a ROS name does not allow turned into `_`.
//!
//! A camera name is one chunk of letters, digits, `_`, `-` and `.`: it lands in a key, a JSON
//! string and a ROS topic unescaped, so nothing that would need escaping in any of them is let
//! through.

use core::fmt;

use super::ros::POINT_STAMPED;

/// Longest camera name: a host name's limit.
pub const MAX_CAMERA_NAME_BYTES: usize = 64;

/// The chunk under `KEY` that `glint fuse --publish KEY` publishes its fused steps on
/// ([`super::fused`]): no camera may take it as its name.
pub const FUSED_CHUNK: &str = "fused";

/// Longest `--publish` key.
pub const MAX_KEY_BYTES: usize = 256;

/// A `--publish` key or camera name that cannot be published under.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum KeyError {
    /// Empty, too long, or with a character outside the allowed set.
    BadCameraName(String),
    /// Not a key expression zenoh can publish on (empty chunk, wildcard, reserved character).
    BadKey(String),
}

impl fmt::Display for KeyError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            KeyError::BadCameraName(name) => write!(
                f,
                "camera name {name:?} must be 1 to {MAX_CAMERA_NAME_BYTES} letters, digits, \
                 '_', '-' or '.', and not {FUSED_CHUNK:?} (glint fuse's key)"
            ),
            KeyError::BadKey(key) => write!(
                f,
                "publish key {key:?} must be up to {MAX_KEY_BYTES} bytes of '/'-separated \
                 non-empty chunks without wildcards ('*'), '$', '#', '?' or a leading '@'"
            ),
        }
    }
}

impl core::error::Error for KeyError {}

/// Every key expression of one camera's reports.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Keys {
    /// `KEY/CAM`: JSON lines.
    pub json: String,
    /// `KEY/CAM/bin`: the binary form.
    pub binary: String,
    /// `KEY/CAM/point`: PointStamped for zenoh-bridge-ros2dds.
    pub bridge_point: String,
    /// rmw_zenoh's key of topic `/KEY/CAM/point`.
    pub rmw_point: String,
    /// The camera name, as it appears in the JSON lines.
    pub camera: String,
}

impl Keys {
    /// The keys of camera `camera` under `key`, for ROS domain `ros_domain_id`.
    pub fn new(key: &str, camera: &str, ros_domain_id: u32) -> Result<Keys, KeyError> {
        check_camera_name(camera)?;
        check_key(key)?;
        let json = format!("{key}/{camera}");
        let bridge_point = format!("{json}/point");
        let rmw_point = format!(
            "{ros_domain_id}/{}/{}/{}",
            ros_topic_path(&bridge_point),
            POINT_STAMPED.dds_name,
            POINT_STAMPED.type_hash
        );
        Ok(Keys {
            binary: format!("{json}/bin"),
            json,
            bridge_point,
            rmw_point,
            camera: camera.to_owned(),
        })
    }
}

fn check_camera_name(camera: &str) -> Result<(), KeyError> {
    let allowed = |c: char| c.is_ascii_alphanumeric() || matches!(c, '_' | '-' | '.');
    if camera.is_empty()
        || camera.len() > MAX_CAMERA_NAME_BYTES
        || !camera.chars().all(allowed)
        || camera == FUSED_CHUNK
    {
        return Err(KeyError::BadCameraName(camera.to_owned()));
    }
    Ok(())
}

/// Zenoh's rules for a key one publishes on: chunks separated by `/`, none empty, no wildcard
/// (`*`, `**`, `$*`), none of `#`, `?`, `$` (reserved), and not the admin space (`@`).
pub(super) fn check_key(key: &str) -> Result<(), KeyError> {
    let bad_chunk =
        |c: &str| c.is_empty() || c.starts_with('@') || c.contains(['*', '$', '#', '?']);
    if key.len() > MAX_KEY_BYTES || key.split('/').any(bad_chunk) {
        return Err(KeyError::BadKey(key.to_owned()));
    }
    Ok(())
}

/// A key as a ROS topic's path (without its leading `/`): a ROS name allows letters, digits and
/// `_` in each token, and a token may not start with a digit; anything else becomes `_`, and a
/// token that starts with a digit gets a leading `_`.
fn ros_topic_path(key: &str) -> String {
    let mut path = String::with_capacity(key.len() + 8);
    for (i, token) in key.split('/').enumerate() {
        if i > 0 {
            path.push('/');
        }
        if token.starts_with(|c: char| c.is_ascii_digit()) {
            path.push('_');
        }
        path.extend(token.chars().map(|c| {
            if c.is_ascii_alphanumeric() || c == '_' {
                c
            } else {
                '_'
            }
        }));
    }
    path
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_camera_publishes_under_four_keys() {
        let keys = Keys::new("lab/glint", "pi-cam.1", 7).unwrap();
        assert_eq!(keys.json, "lab/glint/pi-cam.1");
        assert_eq!(keys.binary, "lab/glint/pi-cam.1/bin");
        assert_eq!(keys.bridge_point, "lab/glint/pi-cam.1/point");
        let prefix = "7/lab/glint/pi_cam_1/point/geometry_msgs::msg::dds_::PointStamped_/RIHS01_";
        assert!(keys.rmw_point.starts_with(prefix), "{}", keys.rmw_point);
        assert_eq!(keys.rmw_point.len(), prefix.len() + 64);
    }

    #[test]
    fn ros_tokens_never_start_with_a_digit() {
        assert_eq!(
            ros_topic_path("glint/2nd-cam/point"),
            "glint/_2nd_cam/point"
        );
    }

    #[test]
    fn bad_names_and_keys_are_refused() {
        for camera in [
            "",
            "a/b",
            "cam*",
            "caméra",
            "a b",
            "\"",
            &"x".repeat(65),
            "fused",
        ] {
            assert!(
                matches!(
                    Keys::new("glint", camera, 0),
                    Err(KeyError::BadCameraName(_))
                ),
                "{camera:?}"
            );
        }
        for key in [
            "", "/glint", "glint/", "a//b", "glint/*", "a/**", "@/x", "a$", "a#b", "a?",
        ] {
            assert!(
                matches!(Keys::new(key, "cam", 0), Err(KeyError::BadKey(_))),
                "{key:?}"
            );
        }
        let long = "k".repeat(MAX_KEY_BYTES + 1);
        assert!(Keys::new(&long, "cam", 0).is_err());
        let message = Keys::new("a/*", "cam", 0).unwrap_err().to_string();
        assert!(message.starts_with("publish key \"a/*\""), "{message}");
    }
}
