//! The floor position as a ROS 2 `geometry_msgs/msg/PointStamped`, for a ROS user on
//! rmw_zenoh or behind zenoh-bridge-ros2dds.
//!
//! Both carry a message as its CDR serialisation (little-endian, XCDR1, the 4-byte
//! encapsulation header `00 01 00 00` first). zenoh-bridge-ros2dds routes ROS topic `/a/b` to
//! zenoh key `a/b` with that payload, so publishing it on `KEY/CAM/point` reaches a ROS node
//! through the bridge. rmw_zenoh names a topic's key
//! `<domain id>/<topic without its leading '/'>/<DDS type name>/<type hash>` and expects an
//! attachment on every sample: its sequence number (i64), source time (i64, ns) and a 16-byte
//! publisher id, serialised as zenoh-ext does (little-endian integers, the id as a sequence
//! with a one-byte LEB128 length, 16).
//!
//! The point is in metres on the floor map, `z` 0 (the floor plane); `header.stamp` is the
//! capture time on the wall clock, `header.frame_id` [`FRAME_ID`]. Frames without a floor
//! position send nothing: a `PointStamped` cannot say "not found".

/// `header.frame_id` of every point: the floor map of the calibration.
pub const FRAME_ID: &str = "glint_floor";

/// A ROS message type as rmw_zenoh names it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RosType {
    /// The DDS type name (`pkg::msg::dds_::Name_`).
    pub dds_name: &'static str,
    /// The ROS 2 type hash (REP 2011, `RIHS01_` and the SHA-256 of the type's description).
    pub type_hash: &'static str,
}

/// `geometry_msgs/msg/PointStamped` (the same in Humble, Jazzy and Rolling).
pub const POINT_STAMPED: RosType = RosType {
    dds_name: "geometry_msgs::msg::dds_::PointStamped_",
    type_hash: "RIHS01_4c0296af86e01e562e9e0405d138a01537247580076c58ea38d7923ac1045897",
};

/// CDR little-endian, as the encapsulation header says it.
const CDR_LE_HEADER: [u8; 4] = [0x00, 0x01, 0x00, 0x00];

/// Nanoseconds per microsecond.
const NS_PER_US: u64 = 1_000;
/// Microseconds per second.
const US_PER_S: u64 = 1_000_000;

/// Bytes of an encoded point: header, stamp, frame id (length, text, NUL), padding to 8 and
/// three f64.
pub const POINT_STAMPED_BYTES: usize = {
    let unpadded = 4 + 8 + 4 + FRAME_ID.len() + 1;
    let body = unpadded - 4;
    4 + body.next_multiple_of(8) + 24
};

/// `PointStamped` at floor `(x_m, y_m, 0)`, stamped `unix_us` (µs since 1970 on the wall
/// clock), in CDR.
pub fn point_stamped(x_m: f64, y_m: f64, unix_us: u64) -> [u8; POINT_STAMPED_BYTES] {
    let mut out = [0u8; POINT_STAMPED_BYTES];
    let mut at = 0;
    let mut put = |bytes: &[u8]| {
        if let Some(dst) = out.get_mut(at..at + bytes.len()) {
            dst.copy_from_slice(bytes);
        }
        at += bytes.len();
    };
    put(&CDR_LE_HEADER);
    // builtin_interfaces/Time: int32 sec (wraps in 2038, as ROS's own does), uint32 nanosec.
    let sec = (unix_us / US_PER_S) as i32;
    let nanosec = ((unix_us % US_PER_S) * NS_PER_US) as u32;
    put(&sec.to_le_bytes());
    put(&nanosec.to_le_bytes());
    // string: uint32 length counting the NUL, the bytes, the NUL.
    put(&((FRAME_ID.len() + 1) as u32).to_le_bytes());
    put(FRAME_ID.as_bytes());
    put(&[0]);
    // The point's f64s align to 8 from the end of the encapsulation header; the array is
    // zeroed, so the padding is already there.
    let point_at = POINT_STAMPED_BYTES - 24;
    for (i, v) in [x_m, y_m, 0.0].into_iter().enumerate() {
        let from = point_at + 8 * i;
        if let Some(dst) = out.get_mut(from..from + 8) {
            dst.copy_from_slice(&v.to_le_bytes());
        }
    }
    out
}

/// Bytes of rmw_zenoh's attachment.
pub const ATTACHMENT_BYTES: usize = 8 + 8 + 1 + 16;

/// rmw_zenoh's attachment: `sequence` (from 1), the source time in ns since 1970, and the
/// publisher's 16-byte id.
pub fn attachment(sequence: i64, unix_us: u64, gid: &[u8; 16]) -> [u8; ATTACHMENT_BYTES] {
    let mut out = [0u8; ATTACHMENT_BYTES];
    let ns = i64::try_from(unix_us.saturating_mul(NS_PER_US)).unwrap_or(i64::MAX);
    out[..8].copy_from_slice(&sequence.to_le_bytes());
    out[8..16].copy_from_slice(&ns.to_le_bytes());
    out[16] = gid.len() as u8;
    out[17..].copy_from_slice(gid);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_point_is_laid_out_as_cdr_aligns_it() {
        // 1_700_000_000.25 s.
        let bytes = point_stamped(1.5, -2.25, 1_700_000_000_250_000);
        assert_eq!(&bytes[..4], &CDR_LE_HEADER);
        assert_eq!(
            i32::from_le_bytes(bytes[4..8].try_into().unwrap()),
            1_700_000_000
        );
        assert_eq!(
            u32::from_le_bytes(bytes[8..12].try_into().unwrap()),
            250_000_000
        );
        let len = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
        assert_eq!(&bytes[16..16 + len], b"glint_floor\0");
        // 16 + 12 = 28 bytes, 24 past the header: already a multiple of 8.
        assert_eq!(POINT_STAMPED_BYTES, 28 + 24);
        let f = |at: usize| f64::from_le_bytes(bytes[at..at + 8].try_into().unwrap());
        assert_eq!((f(28), f(36), f(44)), (1.5, -2.25, 0.0));
    }

    #[test]
    fn the_attachment_carries_sequence_time_and_id() {
        let gid = [7u8; 16];
        let a = attachment(42, 1_000_001, &gid);
        assert_eq!(i64::from_le_bytes(a[..8].try_into().unwrap()), 42);
        assert_eq!(
            i64::from_le_bytes(a[8..16].try_into().unwrap()),
            1_000_001_000
        );
        assert_eq!(a[16], 16);
        assert_eq!(&a[17..], &gid);
    }
}
