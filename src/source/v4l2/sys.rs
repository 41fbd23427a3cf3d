//! The raw V4L2 calls that `v4l`'s safe wrappers would panic on, made panic-free.
//!
//! `v4l` 0.14 decodes several driver replies with `unwrap`/`expect`: a camera name that is not
//! UTF-8 (USB product strings are cut at 31 bytes, possibly inside a character), a colorspace or
//! control type newer than the crate, a menu control with step 0. A camera is hostile input like
//! any other, so these few calls go through `v4l`'s ioctl wrapper and its bindings here, and
//! decode the reply leniently. This is the only module of the capture source with `unsafe`.

use std::io;
use std::mem;
use std::os::raw::{c_int, c_void};

use v4l::v4l2::vidioc;
use v4l::v4l_sys::{
    v4l2_buffer, v4l2_capability, v4l2_control, v4l2_fmtdesc, v4l2_format, v4l2_pix_format,
    v4l2_query_ext_ctrl, v4l2_querymenu, v4l2_requestbuffers, V4L2_CAP_DEVICE_CAPS,
    V4L2_CAP_VIDEO_CAPTURE, V4L2_CTRL_FLAG_NEXT_COMPOUND, V4L2_CTRL_FLAG_NEXT_CTRL,
};

const V4L2_BUF_TYPE_VIDEO_CAPTURE: u32 = v4l::v4l_sys::v4l2_buf_type_V4L2_BUF_TYPE_VIDEO_CAPTURE;
const V4L2_MEMORY_MMAP: u32 = v4l::v4l_sys::v4l2_memory_V4L2_MEMORY_MMAP;

/// Runs one ioctl on `arg`.
///
/// # Safety
/// `request` must be an ioctl whose argument type is `T`.
unsafe fn ioctl<T>(fd: c_int, request: vidioc::_IOC_TYPE, arg: &mut T) -> io::Result<()> {
    // SAFETY: the caller pairs `request` with its argument type; `arg` is a live, exclusive
    // reference for the duration of the call.
    unsafe { v4l::v4l2::ioctl(fd, request, arg as *mut T as *mut c_void) }
}

/// A NUL-terminated byte string from a driver, decoded without trusting it to be UTF-8.
fn c_string(bytes: &[u8]) -> String {
    let end = bytes.iter().position(|&b| b == 0).unwrap_or(bytes.len());
    String::from_utf8_lossy(bytes.get(..end).unwrap_or_default()).into_owned()
}

/// What VIDIOC_QUERYCAP says about a device node.
#[derive(Debug, Clone)]
pub struct Capability {
    /// Driver name, e.g. `uvcvideo` or `vivid`.
    pub driver: String,
    /// The device's name, e.g. the webcam's USB product string.
    pub card: String,
    /// Where it is attached, e.g. `usb-0000:00:14.0-1`.
    pub bus_info: String,
    /// Capabilities of this node (not of the whole device).
    pub node_caps: u32,
}

impl Capability {
    /// Whether this node captures single-planar video, the only kind glint reads.
    pub fn is_video_capture(&self) -> bool {
        self.node_caps & V4L2_CAP_VIDEO_CAPTURE != 0
    }
}

pub fn query_capability(fd: c_int) -> io::Result<Capability> {
    // SAFETY: plain-old-data struct, all-zero is a valid value.
    let mut caps: v4l2_capability = unsafe { mem::zeroed() };
    // SAFETY: VIDIOC_QUERYCAP takes a v4l2_capability.
    unsafe { ioctl(fd, vidioc::VIDIOC_QUERYCAP, &mut caps)? };
    let node_caps = if caps.capabilities & V4L2_CAP_DEVICE_CAPS != 0 {
        caps.device_caps
    } else {
        caps.capabilities
    };
    Ok(Capability {
        driver: c_string(&caps.driver),
        card: c_string(&caps.card),
        bus_info: c_string(&caps.bus_info),
        node_caps,
    })
}

/// One pixel format a capture node offers.
#[derive(Debug, Clone)]
pub struct FormatDesc {
    pub fourcc: [u8; 4],
    pub description: String,
}

/// The pixel formats of a capture node (VIDIOC_ENUM_FMT), in the driver's order.
pub fn enum_formats(fd: c_int) -> io::Result<Vec<FormatDesc>> {
    let mut formats = Vec::new();
    // Far above any real device; stops a driver that never ends the list.
    const MAX_FORMATS: u32 = 256;
    for index in 0..MAX_FORMATS {
        // SAFETY: plain-old-data struct.
        let mut desc: v4l2_fmtdesc = unsafe { mem::zeroed() };
        desc.index = index;
        desc.type_ = V4L2_BUF_TYPE_VIDEO_CAPTURE;
        // SAFETY: VIDIOC_ENUM_FMT takes a v4l2_fmtdesc.
        match unsafe { ioctl(fd, vidioc::VIDIOC_ENUM_FMT, &mut desc) } {
            Ok(()) => formats.push(FormatDesc {
                fourcc: desc.pixelformat.to_le_bytes(),
                description: c_string(&desc.description),
            }),
            // EINVAL marks the end of the list.
            Err(e) if e.raw_os_error() == Some(libc::EINVAL) => break,
            Err(e) => return Err(e),
        }
    }
    Ok(formats)
}

/// The fields of a single-planar format glint uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PixFormat {
    pub width_px: u32,
    pub height_px: u32,
    pub fourcc: [u8; 4],
    pub bytes_per_line: u32,
    pub size_image: u32,
}

fn pix_format(pix: &v4l2_pix_format) -> PixFormat {
    PixFormat {
        width_px: pix.width,
        height_px: pix.height,
        fourcc: pix.pixelformat.to_le_bytes(),
        bytes_per_line: pix.bytesperline,
        size_image: pix.sizeimage,
    }
}

/// Asks for a capture format (VIDIOC_S_FMT) and returns what the driver made of it, which may
/// differ: drivers adjust sizes and formats to the nearest they support.
pub fn set_format(
    fd: c_int,
    width_px: u32,
    height_px: u32,
    fourcc: [u8; 4],
) -> io::Result<PixFormat> {
    // SAFETY: plain-old-data struct.
    let mut format: v4l2_format = unsafe { mem::zeroed() };
    format.type_ = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    // Writing the `pix` member of the zeroed union selects it; capture formats use `pix`.
    format.fmt.pix.width = width_px;
    format.fmt.pix.height = height_px;
    format.fmt.pix.pixelformat = u32::from_le_bytes(fourcc);
    format.fmt.pix.field = v4l::v4l_sys::v4l2_field_V4L2_FIELD_NONE;
    // SAFETY: VIDIOC_S_FMT takes a v4l2_format.
    unsafe { ioctl(fd, vidioc::VIDIOC_S_FMT, &mut format)? };
    // SAFETY: for a VIDEO_CAPTURE format the driver fills `pix`.
    Ok(pix_format(unsafe { &format.fmt.pix }))
}

/// One control as VIDIOC_QUERY_EXT_CTRL describes it.
#[derive(Debug, Clone)]
pub struct ControlDesc {
    pub id: u32,
    /// The raw V4L2 control type (`V4L2_CTRL_TYPE_*`).
    pub kind: u32,
    pub name: String,
    pub minimum: i64,
    pub maximum: i64,
    pub step: u64,
    pub default: i64,
    pub flags: u32,
}

/// Every control of a node, in the driver's order (class headings included; callers skip them).
pub fn query_controls(fd: c_int) -> io::Result<Vec<ControlDesc>> {
    let mut controls = Vec::new();
    let mut id = 0u32;
    // Far above any real device (vivid has about 150); stops a driver that loops.
    const MAX_CONTROLS: usize = 1024;
    while controls.len() < MAX_CONTROLS {
        // SAFETY: plain-old-data struct.
        let mut query: v4l2_query_ext_ctrl = unsafe { mem::zeroed() };
        query.id = id | V4L2_CTRL_FLAG_NEXT_CTRL | V4L2_CTRL_FLAG_NEXT_COMPOUND;
        // SAFETY: VIDIOC_QUERY_EXT_CTRL takes a v4l2_query_ext_ctrl.
        match unsafe { ioctl(fd, vidioc::VIDIOC_QUERY_EXT_CTRL, &mut query) } {
            Ok(()) => {}
            Err(e) if e.raw_os_error() == Some(libc::EINVAL) => break,
            Err(e) => return Err(e),
        }
        if query.id <= id {
            break; // a driver that does not advance would loop forever
        }
        id = query.id;
        // `c_char` is i8 on x86 and u8 on ARM; reinterpret the bytes either way.
        let name_bytes: Vec<u8> = query
            .name
            .iter()
            .map(|&c| u8::from_ne_bytes(c.to_ne_bytes()))
            .collect();
        controls.push(ControlDesc {
            id: query.id,
            kind: query.type_,
            name: c_string(&name_bytes),
            minimum: query.minimum,
            maximum: query.maximum,
            step: query.step,
            default: query.default_value,
            flags: query.flags,
        });
    }
    Ok(controls)
}

/// The item of a menu control at `index` (VIDIOC_QUERYMENU): its name for a text menu, or its
/// value for an integer menu. `None` when the driver skips that index, which the API allows.
pub fn query_menu_item(fd: c_int, id: u32, index: u32, integer_menu: bool) -> Option<String> {
    // SAFETY: plain-old-data struct.
    let mut item: v4l2_querymenu = unsafe { mem::zeroed() };
    item.id = id;
    item.index = index;
    // SAFETY: VIDIOC_QUERYMENU takes a v4l2_querymenu.
    unsafe { ioctl(fd, vidioc::VIDIOC_QUERYMENU, &mut item) }.ok()?;
    // SAFETY: the union holds `value` for integer menus and `name` otherwise.
    Some(unsafe {
        if integer_menu {
            // The union sits in a packed struct: copy the value out instead of referencing it.
            let value = item.__bindgen_anon_1.value;
            value.to_string()
        } else {
            c_string(&item.__bindgen_anon_1.name)
        }
    })
}

/// The current value of a control of 32 bits or less (VIDIOC_G_CTRL).
pub fn get_control(fd: c_int, id: u32) -> io::Result<i32> {
    let mut control = v4l2_control { id, value: 0 };
    // SAFETY: VIDIOC_G_CTRL takes a v4l2_control.
    unsafe { ioctl(fd, vidioc::VIDIOC_G_CTRL, &mut control)? };
    Ok(control.value)
}

/// Sets a control of 32 bits or less (VIDIOC_S_CTRL). Drivers may round the value; read it back.
pub fn set_control(fd: c_int, id: u32, value: i32) -> io::Result<()> {
    let mut control = v4l2_control { id, value };
    // SAFETY: VIDIOC_S_CTRL takes a v4l2_control.
    unsafe { ioctl(fd, vidioc::VIDIOC_S_CTRL, &mut control) }
}

/// Asks the driver for `count` mmap capture buffers (VIDIOC_REQBUFS); returns how many it gave.
/// A count of 0 frees them.
pub fn request_buffers(fd: c_int, count: u32) -> io::Result<u32> {
    // SAFETY: plain-old-data struct.
    let mut request: v4l2_requestbuffers = unsafe { mem::zeroed() };
    request.count = count;
    request.type_ = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    request.memory = V4L2_MEMORY_MMAP;
    // SAFETY: VIDIOC_REQBUFS takes a v4l2_requestbuffers.
    unsafe { ioctl(fd, vidioc::VIDIOC_REQBUFS, &mut request)? };
    Ok(request.count)
}

fn buffer_desc(index: u32) -> v4l2_buffer {
    // SAFETY: plain-old-data struct (the pointer member of its union is unused for mmap).
    let mut buffer: v4l2_buffer = unsafe { mem::zeroed() };
    buffer.index = index;
    buffer.type_ = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    buffer.memory = V4L2_MEMORY_MMAP;
    buffer
}

/// Where buffer `index` lives: `(mmap offset, length in bytes)` (VIDIOC_QUERYBUF).
pub fn query_buffer(fd: c_int, index: u32) -> io::Result<(u32, u32)> {
    let mut buffer = buffer_desc(index);
    // SAFETY: VIDIOC_QUERYBUF takes a v4l2_buffer.
    unsafe { ioctl(fd, vidioc::VIDIOC_QUERYBUF, &mut buffer)? };
    // SAFETY: for mmap buffers the driver fills `offset`.
    Ok((unsafe { buffer.m.offset }, buffer.length))
}

/// Hands buffer `index` to the driver to be filled (VIDIOC_QBUF).
pub fn queue_buffer(fd: c_int, index: u32) -> io::Result<()> {
    let mut buffer = buffer_desc(index);
    // SAFETY: VIDIOC_QBUF takes a v4l2_buffer.
    unsafe { ioctl(fd, vidioc::VIDIOC_QBUF, &mut buffer) }
}

/// What the driver says about a filled buffer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Dequeued {
    pub index: u32,
    pub bytes_used: u32,
    pub flags: u32,
    pub sequence: u32,
    pub timestamp_sec: i64,
    pub timestamp_usec: i64,
}

/// Takes the oldest filled buffer from the driver (VIDIOC_DQBUF); `EAGAIN` when none is ready.
pub fn dequeue_buffer(fd: c_int) -> io::Result<Dequeued> {
    let mut buffer = buffer_desc(0);
    // SAFETY: VIDIOC_DQBUF takes a v4l2_buffer.
    unsafe { ioctl(fd, vidioc::VIDIOC_DQBUF, &mut buffer)? };
    Ok(Dequeued {
        index: buffer.index,
        bytes_used: buffer.bytesused,
        flags: buffer.flags,
        sequence: buffer.sequence,
        timestamp_sec: c_long_to_i64(buffer.timestamp.tv_sec),
        timestamp_usec: c_long_to_i64(buffer.timestamp.tv_usec),
    })
}

/// `time_t` and `suseconds_t` are `long`: 32 bits on 32-bit targets (armv7), 64 elsewhere.
#[allow(clippy::useless_conversion)] // the identity on 64-bit targets
fn c_long_to_i64(value: libc::c_long) -> i64 {
    i64::from(value)
}

/// Starts (`on`) or stops capture streaming (VIDIOC_STREAMON / VIDIOC_STREAMOFF).
pub fn set_streaming(fd: c_int, on: bool) -> io::Result<()> {
    let mut kind: u32 = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    let request = if on {
        vidioc::VIDIOC_STREAMON
    } else {
        vidioc::VIDIOC_STREAMOFF
    };
    // SAFETY: VIDIOC_STREAMON/OFF take the buffer type as an int.
    unsafe { ioctl(fd, request, &mut kind) }
}

/// Waits up to `timeout_ms` for the node to become readable. `Ok(false)` on timeout. Error
/// conditions (an unplugged device reports POLLERR) count as readable, so that the following
/// DQBUF reports the actual error.
pub fn wait_readable(fd: c_int, timeout_ms: i32) -> io::Result<bool> {
    let mut pollfd = libc::pollfd {
        fd,
        events: libc::POLLIN,
        revents: 0,
    };
    // SAFETY: one valid pollfd, count 1.
    let ready = unsafe { libc::poll(&mut pollfd, 1, timeout_ms) };
    match ready {
        -1 => Err(io::Error::last_os_error()),
        0 => Ok(false),
        _ => Ok(true),
    }
}

/// A shared, read-only mapping of one driver buffer.
#[derive(Debug)]
pub struct Mapping {
    ptr: *mut c_void,
    len: usize,
}

impl Mapping {
    /// Maps buffer memory at `offset` of the node (as QUERYBUF told).
    pub fn new(fd: c_int, offset: u32, len: u32) -> io::Result<Self> {
        let len = len as usize;
        // `off_t` is 32 bits on 32-bit targets (armv7); an offset beyond it cannot be mapped.
        #[allow(clippy::unnecessary_fallible_conversions)] // infallible on 64-bit targets
        let offset = libc::off_t::try_from(offset)
            .map_err(|_| io::Error::from(io::ErrorKind::InvalidInput))?;
        // SAFETY: a fresh shared mapping chosen by the kernel; nothing else refers to it.
        let ptr = unsafe {
            libc::mmap(
                std::ptr::null_mut(),
                len,
                libc::PROT_READ,
                libc::MAP_SHARED,
                fd,
                offset,
            )
        };
        if ptr == libc::MAP_FAILED {
            return Err(io::Error::last_os_error());
        }
        Ok(Mapping { ptr, len })
    }

    /// The mapped bytes. The driver writes them only while the buffer is queued, and the stream
    /// lends them out only while it is dequeued.
    pub fn bytes(&self) -> &[u8] {
        // SAFETY: `ptr` maps `len` readable bytes for as long as `self` lives.
        unsafe { std::slice::from_raw_parts(self.ptr as *const u8, self.len) }
    }
}

impl Drop for Mapping {
    fn drop(&mut self) {
        // SAFETY: unmaps exactly what `new` mapped. munmap can only fail on bad arguments,
        // which these are not; there is nothing useful to do about it in a destructor anyway.
        let _ = unsafe { libc::munmap(self.ptr, self.len) };
    }
}

// SAFETY: the mapping is plain memory owned by this value; moving it to another thread is as
// safe as moving a Box<[u8]>. It is not Sync-shared: `bytes` borrows `self`.
unsafe impl Send for Mapping {}

/// Now on the monotonic clock, in microseconds: the clock V4L2 buffer timestamps use, read for
/// drivers whose buffers carry no usable timestamp.
pub fn monotonic_now_us() -> u64 {
    let mut now = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: a valid timespec out-pointer; CLOCK_MONOTONIC always exists on Linux.
    unsafe { libc::clock_gettime(libc::CLOCK_MONOTONIC, &mut now) };
    timeval_us(
        c_long_to_i64(now.tv_sec),
        c_long_to_i64(now.tv_nsec / 1_000),
    )
}

/// Seconds and microseconds as microseconds; negative parts (never valid here) count as 0.
pub fn timeval_us(sec: i64, usec: i64) -> u64 {
    let sec = u64::try_from(sec).unwrap_or(0);
    let usec = u64::try_from(usec).unwrap_or(0);
    sec.saturating_mul(1_000_000).saturating_add(usec)
}
