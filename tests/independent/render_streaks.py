#!/usr/bin/env python3
"""Streak scenes rendered independently of glint's own renderer (glint-scene), to check that
glint's accuracy is not a property of one renderer's physics.

Everything that glint-scene models one way is modelled another way here:

- the spot is a Moffat profile, (1 + r²/α²)^-β, with long power-law wings (lens scatter), or a
  defocused pillbox softened by a small Gaussian, or a Moffat core in a wide Moffat halo;
  glint-scene draws disks and Gaussians;
- the streak is made by depositing the LED's path on a 4× finer grid and convolving it with
  the spot (FFT), then averaging each pixel's 4×4 cells; glint-scene integrates in closed form;
- the sensor counts electrons: Poisson shot noise on a full well, Gaussian read noise in
  electrons, clipping at the full well, then an sRGB-like tone curve (a linear toe and a power)
  or a filmic S-curve, an optional unsharp mask as webcams apply, 8-bit rounding, full or
  studio range; glint-scene adds noise in luma after a pure power law;
- the floor is smoothed random texture under a vignette;
- with `--row-time-us`, a rolling shutter: each sample of the LED's path lights only the rows
  whose own exposure holds its moment, row y's exposure ending y × the row time after row 0's;
  glint-scene draws each row's patch over that row's exposure window.
- with `--flicker DEPTH`, room light that flickers at twice the mains frequency (`--flicker-hz`,
  100 by default): the floor's light (not the LED's) times 1 + DEPTH · sin(2π f t + φ), averaged
  over each row's exposure, so that frames differ in brightness and, under a rolling shutter,
  bands run across each frame; glint-scene lights its floor evenly.

Ground truth is written in glint-scene's truth CSV (frame, t, visible, x, y, mid_x, mid_y, vx,
vy, streak_px, path_mid_x, path_mid_y): x, y is the LED at the end of the exposure, mid at its
middle in time, path_mid halfway along its path, v the velocity at the end of the exposure.
Under a rolling shutter the exposure is the LED's own row's: from the moment the row it is in
starts its exposure to the moment the row it is in then ends it.
Pixel (0, 0)'s centre is the coordinate (0, 0), as in OpenCV.

    render_streaks.py --seed S --count N --out DIR

writes DIR/scene_K.grey (8-bit luma frames, 640×480 unless `--size` says otherwise) and
DIR/scene_K.csv for K < N, and DIR/scenes.json: one object per scene with its parameters (the
exposure in µs and the picture's size among them).
`--row-time-us US` reads the rows out one after another, US apart; each frame's noise then has
a random stream of its own, so that the same seed with `--row-time-us 0` gives the same scenes
under a global shutter (without the option, the scenes of earlier versions).
`--flicker DEPTH` draws each frame's noise from a stream of its own too, so that the same seed
with `--flicker 0` gives the same scenes under a steady room light (their noise differs where
the light does: the shot noise's draws follow it).
`--fps F` shoots the frames F a second instead of 30 (frame n's exposure ends at n / F).
`--motion KIND`, `--spot KIND` and `--frames N` make every scene of that motion, spot or
length (the rest drawn as without them). `--size WxH` draws its scenes from the same
distributions as a camera of that size sees them: every length in pixels (the spot, the
streak, the arc, the floor's texture, where the path lies) scaled by W / 640. The scenes are
not the 640×480 ones scaled: the floor and the noise draw as many numbers as there are pixels,
so from the second scene on the draws differ. Only numpy is used.
"""

import argparse
import json
import math
import os

import numpy as np

WIDTH, HEIGHT = 640, 480
# Pixels of this picture per pixel of a 640-wide one (`--size`).
SCALE = 1.0
FPS = 30.0
MAX_FRAMES = 14
SUPER = 4


def moffat(r2, alpha, beta):
    return (1.0 + r2 / (alpha * alpha)) ** (-beta)


def moffat_fwhm_alpha(fwhm, beta):
    """α of a Moffat profile of this full width at half maximum."""
    return fwhm / (2.0 * math.sqrt(2.0 ** (1.0 / beta) - 1.0))


def spot_kernel(spot, radius_px):
    """The spot's light on the fine grid, normalised to a peak of 1, out to `radius_px`."""
    n = int(math.ceil(radius_px * SUPER))
    c = (np.arange(-n, n + 1) / SUPER)[None, :]
    r2 = c * c + c.T * c.T
    kind = spot["kind"]
    if kind == "moffat":
        k = moffat(r2, spot["alpha_px"], spot["beta"])
    elif kind == "halo":
        k = moffat(r2, spot["alpha_px"], spot["beta"]) + spot["halo_ratio"] * moffat(
            r2, spot["halo_alpha_px"], spot["halo_beta"]
        )
    else:  # a defocused pillbox, its edge softened by a Gaussian
        edge = np.sqrt(r2) - spot["radius_px"]
        k = 0.5 * (1.0 - np.tanh(edge / (spot["soft_px"] * 1.2)))
    # A taper over the last quarter of the reach.
    r = np.sqrt(r2) / radius_px
    k = k * np.where(r < 0.75, 1.0, np.cos(np.clip((r - 0.75) / 0.25, 0, 1) * math.pi / 2) ** 2)
    return k / k.max()


def kernel_reach_px(spot, peak_full_wells):
    """How far the spot's light is drawn: until it is below 3e-4 of a full well (at most 80
    px; the last quarter is tapered, so that no edge shows where it stops)."""
    if spot["kind"] == "pillbox":
        return spot["radius_px"] + 4.0 * spot["soft_px"] + 1.0
    level = 3e-4 / peak_full_wells
    reach = spot["alpha_px"] * math.sqrt(level ** (-1.0 / spot["beta"]) - 1.0)
    if spot["kind"] == "halo":
        level /= spot["halo_ratio"]
        if level < 1.0:
            halo = spot["halo_alpha_px"] * math.sqrt(level ** (-1.0 / spot["halo_beta"]) - 1.0)
            reach = max(reach, halo)
    return min(4.0 / 3.0 * reach + 1.0, 80.0 * SCALE)


def floor_texture(rng, level):
    """Linear-light floor: smoothed noise at two scales under a vignette, mean about `level`."""
    def smooth_noise(cell):
        cell = max(1, int(round(cell * SCALE)))
        h, w = HEIGHT // cell + 2, WIDTH // cell + 2
        coarse = rng.standard_normal((h, w))
        ys = np.arange(HEIGHT) / cell
        xs = np.arange(WIDTH) / cell
        y0, x0 = ys.astype(int), xs.astype(int)
        fy, fx = (ys - y0)[:, None], (xs - x0)[None, :]
        a = coarse[y0][:, x0]
        b = coarse[y0][:, x0 + 1]
        c = coarse[y0 + 1][:, x0]
        d = coarse[y0 + 1][:, x0 + 1]
        return (a * (1 - fx) + b * fx) * (1 - fy) + (c * (1 - fx) + d * fx) * fy

    texture = 1.0 + rng.uniform(0.05, 0.2) * smooth_noise(rng.integers(3, 9)) + rng.uniform(
        0.03, 0.1
    ) * smooth_noise(rng.integers(20, 60))
    yy, xx = np.mgrid[0:HEIGHT, 0:WIDTH]
    r2 = ((xx - WIDTH / 2) ** 2 + (yy - HEIGHT / 2) ** 2) / (WIDTH / 2) ** 2
    vignette = 1.0 - rng.uniform(0.1, 0.35) * r2
    return np.clip(level * texture * vignette, 0.0, None)


class Motion:
    """The LED's position at time t (seconds; frame n's exposure ends at n / FPS)."""

    def __init__(self, rng, kind, exposure_s, streak_px, frames):
        self.kind = kind
        heading = rng.uniform(0, 2 * math.pi)
        self.dir = np.array([math.cos(heading), math.sin(heading)])
        self.speed = streak_px / exposure_s
        self.t0 = -exposure_s
        span_s = (frames - 1) / FPS + exposure_s
        centre = np.array([WIDTH / 2, HEIGHT / 2]) + SCALE * rng.uniform(-60, 60, 2)
        if kind == "arc":
            self.radius = SCALE * rng.uniform(25, 120)
            self.omega = self.speed / self.radius * rng.choice([-1, 1])
            self.phase = rng.uniform(0, 2 * math.pi)
            self.centre = centre
        elif kind == "accelerate":
            # From a third of the speed to the full speed at the last frame's end.
            self.v0 = self.speed / 3
            self.accel = (self.speed - self.v0) / span_s
            self.start = centre - self.dir * (self.v0 + 0.5 * self.accel * span_s) * span_s / 2
        elif kind == "settle":
            # Moves 40 px into place over the first 3 to 5 frames with a raised-cosine speed,
            # then stands, or creeps at up to 3 px/s.
            self.move_s = rng.uniform(3, 5) / FPS
            self.move_px = 40.0 * SCALE
            self.creep = SCALE * rng.uniform(0.0, 3.0)
            self.start = centre - self.dir * 20 * SCALE
        else:
            self.start = centre - self.dir * self.speed * span_s / 2

    def at(self, t):
        s = np.asarray(t, dtype=float) - self.t0
        if self.kind == "line":
            d = self.speed * s
        elif self.kind == "accelerate":
            d = self.v0 * s + 0.5 * self.accel * s * s
        elif self.kind == "settle":
            u = np.clip(s / self.move_s, 0, 1)
            d = self.move_px * (u - np.sin(2 * math.pi * u) / (2 * math.pi)) + self.creep * s
        else:
            a = self.phase + self.omega * s
            return np.stack(
                [self.centre[0] + self.radius * np.cos(a), self.centre[1] + self.radius * np.sin(a)],
                axis=-1,
            )
        return self.start + np.multiply.outer(d, self.dir)


def tone(v, camera):
    """Linear light 0..1 (1 = full well) to 0..1 output."""
    v = np.clip(v, 0.0, 1.0)
    if camera["curve"] == "srgb":
        g = camera["gamma"]
        toe = 0.0031308
        return np.where(v <= toe, 12.92 * v, 1.055 * v ** (1.0 / g) - 0.055)
    # A filmic S: a power, then a soft shoulder that reaches 1 at full well.
    x = v ** (1.0 / camera["gamma"])
    s = camera["shoulder"]
    return x * (1 + s) / (x + s)


def sampled_path(motion, t_start, t_end):
    """The LED's path from `t_start` to `t_end`, sampled finely enough that no fine cell is
    skipped: the sample times (the middles of equal steps), the positions and the length."""
    probe = motion.at(np.linspace(t_start, t_end, 65))
    length = float(np.sum(np.linalg.norm(np.diff(probe, axis=0), axis=1)))
    steps = max(64, int(length * SUPER * 4))
    times = np.linspace(t_start, t_end, steps + 1)
    times = 0.5 * (times[1:] + times[:-1])
    return times, motion.at(times), length


def streak_light(motion, kernel, t_start, t_end):
    """The light of the LED swept from `t_start` to `t_end`, per pixel of a window around the
    path (a still spot's peak is 1): the window's top-left pixel, the light, the sampled path
    and its length."""
    reach = kernel.shape[0] // 2
    times, path, length = sampled_path(motion, t_start, t_end)
    lo = np.floor(path.min(axis=0) - reach / SUPER - 2).astype(int)
    hi = np.ceil(path.max(axis=0) + reach / SUPER + 2).astype(int)
    w, h = hi[0] - lo[0] + 1, hi[1] - lo[1] + 1
    # Fine cell (i, j) of the window has its centre at lo + ((i, j) + 0.5) / SUPER - 0.5; the
    # grid has `reach` spare cells after the window, so that the circular convolution's spill
    # does not wrap onto it.
    fine = np.zeros((h * SUPER + reach, w * SUPER + reach))
    fx = (path[:, 0] - lo[0] + 0.5) * SUPER - 0.5
    fy = (path[:, 1] - lo[1] + 0.5) * SUPER - 0.5
    ix, iy = np.floor(fx).astype(int), np.floor(fy).astype(int)
    ax, ay = fx - ix, fy - iy
    weight = 1.0 / len(times)
    for dx, dy, share in (
        (0, 0, (1 - ax) * (1 - ay)),
        (1, 0, ax * (1 - ay)),
        (0, 1, (1 - ax) * ay),
        (1, 1, ax * ay),
    ):
        np.add.at(fine, (iy + dy, ix + dx), share * weight)
    light = np.fft.irfft2(np.fft.rfft2(fine) * np.fft.rfft2(kernel, s=fine.shape), s=fine.shape)
    # The kernel's centre is its cell (reach, reach): a deposit at cell c lands at c + reach.
    light = light[reach : reach + h * SUPER, reach : reach + w * SUPER]
    return lo, light.reshape(h, SUPER, w, SUPER).mean(axis=(1, 3)), path, length


def pixel_kernels(kernel):
    """The spot's light on the picture's pixels for a point at each of the fine grid's SUPER ×
    SUPER phases within a pixel: `out[b][a]` is the 4×4 block mean of `kernel` centred on fine
    cell (b, a) of a pixel, with the centre pixel at index `m` of each axis. A point deposited
    at that phase and then convolved and block-averaged (as `streak_light` does) gives exactly
    this."""
    n = kernel.shape[0] // 2
    m = -(-n // SUPER) + 1
    size = SUPER * (2 * m + 1)
    out = []
    for b in range(SUPER):
        row = []
        for a in range(SUPER):
            grid = np.zeros((size, size))
            y0, x0 = SUPER * m + b - n, SUPER * m + a - n
            grid[y0 : y0 + 2 * n + 1, x0 : x0 + 2 * n + 1] = kernel
            row.append(grid.reshape(2 * m + 1, SUPER, 2 * m + 1, SUPER).mean(axis=(1, 3)))
        out.append(row)
    return out, m


def seen_in_its_row(motion, t_row0, row_time_s):
    """The moment `t` at which the LED is in the row whose exposure is at `t_row0`'s point of
    row 0's: `t = t_row0 + y(t) × row time`, by fixed-point steps (each shrinks the error by
    the rows the LED crosses in a row time, a small fraction)."""
    t = t_row0
    for _ in range(20):
        t = t_row0 + max(float(motion.at(t)[1]), 0.0) * row_time_s
    return t


def rolling_light(motion, pixel, m, t_start, t_end, row_time_s):
    """The light of the LED seen by a rolling shutter, as `streak_light` gives it for a global
    one: row y sees it from `t_start + y τ` to `t_end + y τ`. Each sample of the path lights its
    four fine cells' pixel kernels (`pixel_kernels`), on the rows whose exposure holds it."""
    exposure_s = t_end - t_start
    # The rows the light can reach: around the LED's own rows while any row can see it.
    t_first = seen_in_its_row(motion, t_start, row_time_s)
    t_last = seen_in_its_row(motion, t_end, row_time_s)
    probe = motion.at(np.linspace(t_first, t_last, 65))
    row_lo = max(int(math.floor(probe[:, 1].min())) - m - 1, 0)
    row_hi = min(int(math.ceil(probe[:, 1].max())) + m + 1, HEIGHT - 1)
    # Every moment some row of those sees, sampled as densely as a global exposure is.
    length = float(np.sum(np.linalg.norm(np.diff(probe, axis=0), axis=1)))
    dt = exposure_s / max(64, int(length * SUPER * 4))
    t0, t1 = t_start + row_lo * row_time_s, t_end + row_hi * row_time_s
    steps = int(math.ceil((t1 - t0) / dt))
    times = t0 + (np.arange(steps) + 0.5) * (t1 - t0) / steps
    weight = (t1 - t0) / steps / exposure_s
    path = motion.at(times)
    lo = np.floor(path.min(axis=0)).astype(int) - m - 1
    hi = np.ceil(path.max(axis=0)).astype(int) + m + 2
    lo[1], hi[1] = row_lo, row_hi + 1
    light = np.zeros((hi[1] - lo[1], hi[0] - lo[0]))
    # Rows whose exposure holds each moment: t_start + y τ <= t <= t_end + y τ.
    first_row = np.ceil((times - t_end) / row_time_s).astype(int)
    last_row = np.floor((times - t_start) / row_time_s).astype(int)
    fx = (path[:, 0] + 0.5) * SUPER - 0.5
    fy = (path[:, 1] + 0.5) * SUPER - 0.5
    ix, iy = np.floor(fx).astype(int), np.floor(fy).astype(int)
    ax, ay = fx - ix, fy - iy
    for k in range(steps):
        for dx, dy, share in (
            (0, 0, (1 - ax[k]) * (1 - ay[k])),
            (1, 0, ax[k] * (1 - ay[k])),
            (0, 1, (1 - ax[k]) * ay[k]),
            (1, 1, ax[k] * ay[k]),
        ):
            cx, cy = ix[k] + dx, iy[k] + dy
            px, py = cx // SUPER, cy // SUPER
            kern = pixel[cy % SUPER][cx % SUPER]
            # The kernel's rows y in [py - m, py + m], cut to the rows that see this moment.
            y0 = max(py - m, first_row[k], lo[1])
            y1 = min(py + m, last_row[k], hi[1] - 1)
            if y1 < y0:
                continue
            light[y0 - lo[1] : y1 + 1 - lo[1], px - m - lo[0] : px + m + 1 - lo[0]] += (
                share * weight * kern[y0 - py + m : y1 + 1 - py + m]
            )
    return lo, light


def room_light(force, phase, frame_start, frame_end, row_time_s):
    """The room light on the floor over each row's exposure, relative to its mean: a column of
    factors (one per row), or 1 without `--flicker`. Light at `1 + d sin(ω t + φ)` averages to
    `1 + d (cos(ω a + φ) − cos(ω b + φ)) / (ω (b − a))` over an exposure from `a` to `b`."""
    depth = force.flicker or 0.0
    if depth == 0.0:
        return 1.0
    omega = 2 * math.pi * force.flicker_hz
    rows = np.arange(HEIGHT, dtype=float)[:, None] * row_time_s
    a, b = frame_start + rows, frame_end + rows
    return 1.0 + depth * (np.cos(omega * a + phase) - np.cos(omega * b + phase)) / (omega * (b - a))


def render_scene(rng, index, force):
    # The streak's length in one exposure, 2 to 60 px; a long one needs a long exposure.
    streak_px = float(rng.choice([rng.uniform(2, 20), rng.uniform(20, 40), 60.0]))
    exposure_s = float(rng.uniform(4e-3, 30e-3) if streak_px < 20 else rng.uniform(15e-3, 30e-3))
    motion_kind = force.motion or str(rng.choice(["line", "line", "arc", "accelerate", "settle"]))
    # A straight run: as many frames as stay inside the middle of the picture at that speed.
    frames = force.frames or MAX_FRAMES
    if motion_kind in ("line", "accelerate"):
        per_frame_px = streak_px / exposure_s / FPS
        frames = int(np.clip(300 / per_frame_px, 4, MAX_FRAMES))
    streak_px *= SCALE
    kind = str(rng.choice(["moffat", "moffat", "halo", "pillbox"]))
    kind = force.spot or kind
    spot = {"kind": kind}
    if kind == "pillbox":
        spot.update(
            radius_px=SCALE * float(rng.uniform(0.8, 3.0)),
            soft_px=SCALE * float(rng.uniform(0.3, 0.8)),
        )
    else:
        fwhm = SCALE * float(rng.uniform(1.5, 6.0))
        beta = float(rng.uniform(2.5, 5.0))
        spot.update(fwhm_px=fwhm, beta=beta, alpha_px=moffat_fwhm_alpha(fwhm, beta))
        if kind == "halo":
            halo_beta = float(rng.uniform(2.0, 3.5))
            spot.update(
                halo_ratio=float(rng.uniform(0.02, 0.08)),
                halo_beta=halo_beta,
                halo_alpha_px=moffat_fwhm_alpha(fwhm * rng.uniform(3, 5), halo_beta),
            )
    camera = {
        "curve": str(rng.choice(["srgb", "filmic"])),
        "gamma": float(rng.uniform(1.8, 2.4)),
        "shoulder": float(rng.uniform(0.3, 1.0)),
        "full_well_e": float(rng.uniform(3000, 15000)),
        "read_noise_e": float(rng.uniform(2, 15)),
        "sharpen": float(rng.choice([0.0, rng.uniform(0.2, 0.7)])),
        "studio": bool(rng.random() < 0.4),
    }
    # The LED's peak in the dimmest frame's streak, in full wells: barely saturating to
    # strongly (a still spot's peak is brighter by the streak's length over its width).
    streak_peak_full_wells = float(np.exp(rng.uniform(math.log(1.3), math.log(30.0))))
    floor_level = float(rng.uniform(0.01, 0.12))
    floor = floor_texture(rng, floor_level)
    motion = Motion(rng, motion_kind, exposure_s, streak_px, frames)
    times = [(n / FPS - exposure_s, n / FPS) for n in range(frames)]
    # The still spot's peak that gives that: the streaks' peaks measured on a short kernel.
    short = spot_kernel(spot, kernel_reach_px(spot, 1.0))
    dimmest = min(streak_light(motion, short, *t)[1].max() for t in times)
    peak_full_wells = streak_peak_full_wells / dimmest
    kernel = spot_kernel(spot, kernel_reach_px(spot, peak_full_wells))
    row_time_s = (force.row_time_us or 0.0) * 1e-6
    if row_time_s > 0:
        pixel, m = pixel_kernels(kernel)
    # The room light's phase at t = 0, from a stream of the scene's own: the other draws stay
    # those of the steady scene.
    flicker_phase = float(np.random.default_rng([force.seed, index]).uniform(0, 2 * math.pi))
    own_noise = force.row_time_us is not None or force.flicker is not None

    out = bytearray()
    truths = []
    for n, (frame_start, frame_end) in enumerate(times):
        if row_time_s > 0:
            lo, light = rolling_light(motion, pixel, m, frame_start, frame_end, row_time_s)
            # The LED's own exposure: from its row's start to its row's end.
            t_start = seen_in_its_row(motion, frame_start, row_time_s)
            t_end = seen_in_its_row(motion, frame_end, row_time_s)
            _, path, length = sampled_path(motion, t_start, t_end)
        else:
            t_start, t_end = frame_start, frame_end
            lo, light, path, length = streak_light(motion, kernel, t_start, t_end)
        h, w = light.shape
        # A still spot's peak is 1 before scaling (the kernel's peak, the path's weight 1);
        # what falls outside the picture is dropped.
        irradiance = floor * room_light(force, flicker_phase, frame_start, frame_end, row_time_s)
        x0, y0 = max(lo[0], 0), max(lo[1], 0)
        x1, y1 = min(lo[0] + w, WIDTH), min(lo[1] + h, HEIGHT)
        irradiance[y0:y1, x0:x1] += peak_full_wells * np.clip(
            light[y0 - lo[1] : y1 - lo[1], x0 - lo[0] : x1 - lo[0]], 0, None
        )
        # How many numbers the shot noise draws depends on the light, so under a rolling
        # shutter each frame's noise has a stream of its own: the scenes' other draws then stay
        # those of the same seed's global shutter (`--row-time-us 0`).
        noise = np.random.default_rng([force.seed, index, n]) if own_noise else rng
        electrons = noise.poisson(irradiance * camera["full_well_e"]).astype(float)
        electrons += noise.normal(0.0, camera["read_noise_e"], electrons.shape)
        v = tone(electrons / camera["full_well_e"], camera)
        if camera["sharpen"] > 0:
            blur = (np.roll(v, 1, 0) + np.roll(v, -1, 0) + np.roll(v, 1, 1) + np.roll(v, -1, 1) + 4 * v) / 8
            v = v + camera["sharpen"] * (v - blur)
        v = np.clip(v, 0.0, 1.0)
        luma = 16 + 219 * v if camera["studio"] else 255 * v
        out += np.clip(np.rint(luma), 0, 255).astype(np.uint8).tobytes()

        head = motion.at(t_end)
        mid = motion.at(0.5 * (t_start + t_end))
        along = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(path, axis=0), axis=1))])
        path_mid = path[min(np.searchsorted(along, along[-1] / 2), len(path) - 1)]
        dt = 1e-6
        vel = (motion.at(t_end) - motion.at(t_end - dt)) / dt
        # Visible (1) when the whole streak is in the picture, partly (-1) when it is cut by
        # its border, hidden (0) when none of it is in.
        margin = 3.0
        inside = (
            (path[:, 0] >= margin)
            & (path[:, 0] <= WIDTH - 1 - margin)
            & (path[:, 1] >= margin)
            & (path[:, 1] <= HEIGHT - 1 - margin)
        )
        visible = 1 if inside.all() else (-1 if inside.any() else 0)
        truths.append(
            f"{n},{frame_end:.6f},{visible},{head[0]:.4f},{head[1]:.4f},{mid[0]:.4f},{mid[1]:.4f},"
            f"{vel[0]:.3f},{vel[1]:.3f},{length:.4f},{path_mid[0]:.4f},{path_mid[1]:.4f}"
        )
    params = {
        "scene": index,
        "size": f"{WIDTH}x{HEIGHT}",
        "frames": frames,
        "exposure_us": int(round(exposure_s * 1e6)),
        "streak_px": streak_px,
        "spot": spot,
        "camera": camera,
        "streak_peak_full_wells": streak_peak_full_wells,
        "peak_full_wells": peak_full_wells,
        "floor_level": floor_level,
        "motion": motion.kind,
        # The first frame whose exposure starts after an LED moving into place stopped.
        "settled_frame": math.ceil(motion.move_s * FPS) if motion.kind == "settle" else 0,
        "row_time_us": force.row_time_us or 0.0,
        "flicker": force.flicker or 0.0,
        "flicker_hz": force.flicker_hz,
        "fps": FPS,
    }
    return bytes(out), truths, params


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seed", type=int, required=True)
    parser.add_argument("--count", type=int, required=True)
    parser.add_argument("--out", required=True)
    # Every scene of one kind, for a check of that kind (the random draws stay the same).
    parser.add_argument("--motion", choices=["line", "arc", "accelerate", "settle"])
    parser.add_argument("--spot", choices=["moffat", "halo", "pillbox"])
    parser.add_argument("--frames", type=int, help="frames of an arc or a settling LED")
    parser.add_argument("--size", default="640x480", help="the picture's WxH")
    parser.add_argument(
        "--row-time-us", type=float, help="a rolling shutter's row time, µs (0: a global shutter)"
    )
    parser.add_argument(
        "--flicker",
        type=float,
        help="the room light's flicker depth on the floor, 0 to 1 (0: steady, own noise streams)",
    )
    parser.add_argument(
        "--flicker-hz", type=float, default=100.0, help="the room light's flicker frequency"
    )
    parser.add_argument("--fps", type=float, default=30.0, help="frames a second")
    args = parser.parse_args()
    global WIDTH, HEIGHT, SCALE, FPS
    if not 0.0 < args.fps <= 1000.0:
        parser.error("--fps must be above 0 and up to 1000")
    FPS = args.fps
    WIDTH, HEIGHT = (int(v) for v in args.size.split("x"))
    SCALE = WIDTH / 640.0
    if args.row_time_us is not None and not 0.0 <= args.row_time_us * HEIGHT <= 1e6 / FPS:
        parser.error("--row-time-us must be at least 0 and read the rows out within a frame")
    if args.flicker is not None and not 0.0 <= args.flicker <= 1.0:
        parser.error("--flicker must be from 0 to 1")
    if not args.flicker_hz > 0.0:
        parser.error("--flicker-hz must be above 0")
    rng = np.random.default_rng(args.seed)
    scenes = []
    for k in range(args.count):
        frames, truths, params = render_scene(rng, k, args)
        with open(os.path.join(args.out, f"scene_{k}.grey"), "wb") as f:
            f.write(frames)
        with open(os.path.join(args.out, f"scene_{k}.csv"), "w") as f:
            f.write("frame,t,visible,x,y,mid_x,mid_y,vx,vy,streak_px,path_mid_x,path_mid_y\n")
            f.write("\n".join(truths) + "\n")
        scenes.append(params)
    with open(os.path.join(args.out, "scenes.json"), "w") as f:
        json.dump(scenes, f, indent=1)


if __name__ == "__main__":
    main()
