"""Animations: moving points and rigid bodies, written as GIF or MP4.

The frames are drawn with ``matplotlib.figure.Figure`` and the Agg canvas directly (no GUI backend);
the static part of each frame is rendered once and kept, and only the moving artists are drawn per
frame (blitting).  :func:`view_window` sets the frame from the bodies' motion, never from the scenery
(:func:`clip_polyline` cuts the ground to it).  Static figures are :mod:`.plotting`; the two are the
only modules that import matplotlib.
"""
from __future__ import annotations

from io import BytesIO
from typing import List, Optional

import numpy as np
from matplotlib import animation
from matplotlib.figure import Figure
from PIL import Image


def _as_time(t, label: str) -> np.ndarray:
    t = np.asarray(t, dtype=float).reshape(-1)
    if t.size == 0:
        raise ValueError(f"{label}: the time array is empty")
    return t


def mp4_available() -> bool:
    """Whether an MP4 encoder (ffmpeg) is present for :func:`animate_points`."""
    return bool(animation.FFMpegWriter.isAvailable())


class _SharedPaletteGifWriter(animation.PillowWriter):
    """:class:`~matplotlib.animation.PillowWriter` that quantises every frame to one shared palette.

    Pillow otherwise builds an adaptive palette per RGB frame while saving,
    which costs more than drawing the frames; mapping all frames onto one
    palette (taken from a mosaic of a few frames) is about ten times faster
    and gives a smaller file.  The palette has :attr:`colors` entries: 64 keep
    the antialiased lines and text of a plot clean and make a 640-px, 200-frame
    GIF about 0.8 MB (255: 1.1 MB).  Frames must be opaque.
    """

    colors = 64

    def setup(self, fig, outfile, dpi=None):
        super().setup(fig, outfile, dpi=dpi)
        self._rgb = []

    def grab_frame(self, **savefig_kwargs):
        buf = BytesIO()
        self.fig.savefig(buf, **{**savefig_kwargs, "format": "rgba", "dpi": self.dpi})
        self._rgb.append(Image.frombuffer("RGBA", self.frame_size, buf.getbuffer(), "raw", "RGBA", 0, 1)
                         .convert("RGB"))

    def grab_rgba(self, rgba: np.ndarray) -> None:
        """Add a frame already rendered (an (H, W, 4) uint8 array, e.g. a blitted canvas buffer)."""
        self._rgb.append(Image.fromarray(np.ascontiguousarray(rgba[..., :3])))

    def finish(self):
        frames = self._rgb
        picks = [frames[i] for i in np.unique(np.linspace(0, len(frames) - 1, 8).round().astype(int))]
        w, h = picks[0].size
        mosaic = Image.new("RGB", (w, h * len(picks)))
        for k, im in enumerate(picks):
            mosaic.paste(im, (0, k * h))
        palette = mosaic.quantize(colors=self.colors)
        quantised = [im.quantize(palette=palette, dither=Image.Dither.NONE) for im in frames]
        quantised[0].save(self.outfile, save_all=True, append_images=quantised[1:],
                          duration=int(1000 / self.fps), loop=0)


class _RawFFMpegWriter(animation.FFMpegWriter):
    """:class:`~matplotlib.animation.FFMpegWriter` that also takes frames already rendered (H.264, yuv420p)."""

    def grab_rgba(self, rgba: np.ndarray) -> None:
        """Pipe an (H, W, 4) uint8 frame of the writer's frame size to ffmpeg."""
        if (rgba.shape[1], rgba.shape[0]) != tuple(self.frame_size):
            raise ValueError(f"frame of {rgba.shape[1]} x {rgba.shape[0]} px, the movie is {self.frame_size}")
        self._proc.stdin.write(np.ascontiguousarray(rgba).tobytes())


def _writer(path, fps: int):
    """The animation writer for ``path``: a GIF (Pillow) or an MP4 (ffmpeg); ``ValueError`` otherwise."""
    ext = str(path).lower().rsplit(".", 1)[-1] if "." in str(path) else ""
    if ext == "gif":
        return _SharedPaletteGifWriter(fps=fps)
    if ext == "mp4":
        if not animation.FFMpegWriter.isAvailable():
            raise ValueError(f"cannot write {path}: MP4 needs ffmpeg, which was not found; "
                             "install ffmpeg or ask for a .gif")
        return _RawFFMpegWriter(fps=fps, codec="h264", extra_args=["-pix_fmt", "yuv420p"])
    raise ValueError(f"cannot write {path}: the animation path must end in .gif or .mp4")


def _frames(t: np.ndarray, max_frames: int) -> np.ndarray:
    """Frame indices evenly in time: the last sample at or before each of ``max_frames`` target times."""
    targets = np.linspace(t[0], t[-1], min(t.size, int(max_frames)))
    return np.unique(np.clip(np.searchsorted(t, targets, side="right") - 1, 0, t.size - 1))


#: Every animation's frame: this many inches wide at this many dots per inch (640 px; text and lines
#: scale with the dpi, so they stay readable at the larger size).
ANIMATION_WIDTH_IN = 4.0
ANIMATION_DPI = 160


def time_stamp(t: float) -> str:
    """The time shown in an animation's frame: ``"t = 1.23 s"``."""
    return f"t = {t:.2f} s"


#: Margin of an animation's window around the motion, as a fraction of the motion's largest half-extent.
VIEW_MARGIN = 0.12


def view_window(points, margin: float = VIEW_MARGIN, min_aspect: float = 0.5, cube: bool = False):
    """The view box of an animation: ``(lo, hi)`` around ``points`` (shape (M, d), every position the
    bodies take, every frame).

    One rule for every animation: the box is the points' bounding box, each half-width raised to at
    least ``min_aspect`` of the largest one (all equal with ``cube``, for a 3-D box), then grown by
    ``margin`` of the largest.  Fixed scenery (a ground, a bowl) does not widen it; it is clipped to it.
    """
    P = np.asarray(points, dtype=float).reshape(-1, np.shape(points)[-1])
    lo, hi = P.min(axis=0), P.max(axis=0)
    centre, half = 0.5 * (lo + hi), 0.5 * (hi - lo)
    big = float(half.max())
    if not big > 1e-12 * max(1.0, float(np.abs(centre).max())):  # nothing moves: a unit window around it
        big = 0.5 * max(1.0, float(np.abs(centre).max()))
    half = np.full_like(half, big) if cube else np.maximum(half, min_aspect * big)
    half = half + margin * big
    return centre - half, centre + half


def clip_polyline(poly, lo, hi) -> Optional[np.ndarray]:
    """The parts of the polyline ``poly`` (M, 2) inside the box ``[lo, hi]`` (Liang–Barsky per segment),
    as one polyline with a NaN row between separate pieces; ``None`` when no part is inside."""
    poly = np.asarray(poly, dtype=float).reshape(-1, 2)
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    pieces: List[List[np.ndarray]] = []
    for a, b in zip(poly[:-1], poly[1:]):
        d = b - a
        t0, t1 = 0.0, 1.0
        for k in range(2):
            for p, r in ((-d[k], a[k] - lo[k]), (d[k], hi[k] - a[k])):
                if p == 0.0:
                    if r < 0.0:
                        t0, t1 = 1.0, 0.0
                elif p < 0.0:
                    t0 = max(t0, r / p)
                else:
                    t1 = min(t1, r / p)
        if t0 > t1:
            continue
        pa, pb = a + t0 * d, a + t1 * d
        if pieces and t0 == 0.0 and np.array_equal(pieces[-1][-1], pa):
            pieces[-1].append(pb)
        else:
            pieces.append([pa, pb])
    if not pieces:
        return None
    out = []
    for k, piece in enumerate(pieces):
        if k:
            out.append(np.full(2, np.nan))
        out.extend(piece)
    return np.array(out)


def _view(azimuth: float, elevation: float) -> np.ndarray:
    """The orthographic projection (2 × 3) of space onto the screen of a camera at ``azimuth`` about the vertical
    z axis from −y, and ``elevation`` above the horizon (radians): z stays up."""
    ca_, sa, ce, se = np.cos(azimuth), np.sin(azimuth), np.cos(elevation), np.sin(elevation)
    right = np.array([ca_, sa, 0.0])
    up = np.array([-se * sa, se * ca_, ce])
    return np.vstack([right, up])


#: the view of points in space in :func:`animate_points` (30° round from the front, 20° above): x to the right,
#: z up, y into the picture
VIEW = _view(np.radians(30.0), np.radians(20.0))


class PointsAnimation:
    """The figure of :func:`animate_points` and how to draw one sample on it, before anything is written.

    ``fig`` and ``ax`` are fixed for the whole animation (limits from :func:`view_window`);
    ``frames`` are the sample indices drawn; ``ground`` is the scenery polyline drawn (clipped to the
    window) or ``None``; ``markers`` and ``links`` are the moving artists, set by :meth:`draw`;
    :meth:`render` gives a frame's pixels.  The frame is ``ANIMATION_WIDTH_IN * dpi`` pixels wide
    (640 by default), with the time stamped in its corner (:func:`time_stamp`).
    """

    def __init__(self, positions, t, trail: bool = True, max_frames: int = 200, links: bool = True,
                 pivot=(0.0, 0.0), title: Optional[str] = None, trail_time: float = 1.0,
                 dpi: int = ANIMATION_DPI, ground=None):
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.collections import LineCollection

        P = np.asarray(positions, dtype=float)
        if P.ndim == 2 and P.shape[-1] == 2:
            P = P[:, None, :]
        if P.ndim == 3 and P.shape[-1] == 3:          # points in space: seen along a fixed oblique view
            P = P @ VIEW.T
        if P.ndim != 3 or P.shape[-1] != 2 or P.shape[0] == 0:
            raise ValueError(f"positions must have shape (K, n_points, 2) or (K, n_points, 3), got "
                             f"{np.shape(positions)}")
        t = _as_time(t, "animate_points")
        if t.size != P.shape[0]:
            raise ValueError(f"animate_points: {P.shape[0]} position rows but {t.size} times")
        if not np.all(np.isfinite(t)) or np.any(np.diff(t) < 0):
            raise ValueError("animate_points: t must be finite and non-decreasing")
        if not np.all(np.isfinite(P)):
            raise ValueError("animate_points: positions contain non-finite values")
        if int(max_frames) < 1:
            raise ValueError("animate_points: max_frames must be positive")
        self.P, self.t, self.trail, self.trail_time = P, t, trail, trail_time
        self.frames = _frames(t, max_frames)
        self.has_pivot = pivot is not None
        self.pivot = np.asarray(pivot if self.has_pivot else (0.0, 0.0), dtype=float).reshape(2)
        # links: True (the pivot and the points joined in order), False, or pairs (i, j) of point indices
        # to join (-1: the pivot), e.g. [(0, 1), (0, 2)] for two bobs hanging from one cart
        self.pairs = None
        if not isinstance(links, (bool, np.bool_)):
            pairs = [tuple(int(k) for k in pr) for pr in links]
            n_pts = P.shape[1]
            if any(len(pr) != 2 or not all(-1 <= k < n_pts for k in pr) for pr in pairs):
                raise ValueError(f"links: pairs of point indices in [0, {n_pts}) (-1: the pivot), got {links!r}")
            if any(-1 in pr for pr in pairs) and not self.has_pivot:
                raise ValueError("links: index -1 joins the pivot, but there is no pivot")
            self.pairs = pairs
        self.show_links = bool(links) if self.pairs is None else bool(self.pairs)
        links = self.show_links

        # the window follows the bodies (and the pivot they hang from), never the scenery
        moving = P.reshape(-1, 2)
        if links and self.has_pivot:
            moving = np.vstack([moving, self.pivot])
        lo, hi = view_window(moving)
        self.ground = None if ground is None else clip_polyline(ground, lo, hi)
        half = 0.5 * (hi - lo)

        # figure shaped to the window (aspect clamped), in even pixel counts as ffmpeg wants
        dpi = int(dpi)
        left, right, bottom, top_in = 0.5, 0.12, 0.35, (0.35 if title else 0.12)
        aspect = float(np.clip(half[1] / half[0], 0.4, 1.2))
        width_px = 2 * round(ANIMATION_WIDTH_IN * dpi / 2)
        axes_w = width_px / dpi - left - right
        height_px = 2 * round((axes_w * aspect + bottom + top_in) * dpi / 2)
        fig = Figure(figsize=(width_px / dpi, height_px / dpi), dpi=dpi)
        canvas = FigureCanvasAgg(fig)
        W, H = width_px / dpi, height_px / dpi
        fig.subplots_adjust(left=left / W, right=1 - right / W, bottom=bottom / H, top=1 - top_in / H)
        ax = fig.add_subplot()
        ax.set_xlim(lo[0], hi[0])
        ax.set_ylim(lo[1], hi[1])
        ax.set_aspect("equal", adjustable="box")
        ax.tick_params(labelsize=7)
        ax.grid(True, alpha=0.2)
        if title:
            ax.set_title(title, fontsize=9)
        if links and self.has_pivot:
            ax.plot([self.pivot[0]], [self.pivot[1]], "s", color="k", ms=4)
        if self.ground is not None:
            ax.plot(self.ground[:, 0], self.ground[:, 1], "-", color="0.3", lw=1.5)
        # The moving artists are animated: the static part (frame, ticks, grid, title, pivot, ground)
        # is rendered once and kept as a background; each frame restores it and draws only the moving
        # artists on it (blitting), which keeps a 200-frame GIF of 640 px around a second.
        (self.links,) = ax.plot([], [], "-", color="0.25", lw=1.6, visible=links, animated=True)
        self._trail = LineCollection([], linewidths=1.5, animated=True)
        ax.add_collection(self._trail, autolim=False)
        (self.markers,) = ax.plot([], [], "o", color="C0", ms=7, mec="k", mew=0.6, zorder=3, animated=True)
        self._stamp = ax.text(0.02, 0.97, "", transform=ax.transAxes, va="top", fontsize=9, animated=True,
                              bbox=dict(boxstyle="round,pad=0.2", fc="white", ec="0.7", lw=0.5, alpha=0.85))
        canvas.draw()
        self._background = canvas.copy_from_bbox(fig.bbox)
        self.fig, self.ax, self.dpi, self.canvas = fig, ax, dpi, canvas

    def render(self, i: int) -> np.ndarray:
        """The pixels of sample ``i``'s frame: an (H, W, 4) uint8 array (a copy)."""
        self.draw(i)
        self.canvas.restore_region(self._background)
        for artist in (self.links, self._trail, self.markers, self._stamp):
            self.ax.draw_artist(artist)
        return np.array(self.canvas.buffer_rgba())

    def draw(self, i: int) -> None:
        """Set the moving artists to sample ``i``."""
        P, t, pts = self.P, self.t, self.P[i]
        if self.show_links and self.pairs is not None:
            ext = np.vstack([pts, self.pivot[None, :]])          # index -1: the pivot
            seg = np.full((3 * len(self.pairs), 2), np.nan)      # segments separated by NaN rows
            for k, (a, b) in enumerate(self.pairs):
                seg[3 * k], seg[3 * k + 1] = ext[a], ext[b]
            self.links.set_data(seg[:, 0], seg[:, 1])
        elif self.show_links:
            chain = np.vstack([self.pivot, pts]) if self.has_pivot else pts
            self.links.set_data(chain[:, 0], chain[:, 1])
        self.markers.set_data(pts[:, 0], pts[:, 1])
        if self.trail:
            tt = self.trail_time
            j0 = int(np.searchsorted(t, t[i] - tt, side="left"))
            idx = np.arange(j0, i + 1)
            if idx.size > 150:
                idx = np.unique(np.linspace(j0, i, 150).round().astype(int))
            tr = P[idx, -1, :]
            if len(tr) >= 2:
                segs = np.stack([tr[:-1], tr[1:]], axis=1)
                age = (t[i] - t[idx[1:]]) / tt if tt > 0 else np.zeros(len(segs))
                colors = np.empty((len(segs), 4))
                colors[:, :3] = (0.84, 0.15, 0.16)  # C3
                colors[:, 3] = np.clip(1.0 - age, 0.0, 1.0) * 0.9
                self._trail.set_segments(segs)
                self._trail.set_color(colors)
            else:
                self._trail.set_segments([])
        self._stamp.set_text(time_stamp(t[i]))


def animate_points(positions, t, path: str, trail: bool = True, fps: int = 20, max_frames: int = 200,
                   links: bool = True, pivot=(0.0, 0.0), title: Optional[str] = None,
                   trail_time: float = 1.0, dpi: int = ANIMATION_DPI, ground=None) -> str:
    """Animate moving points (e.g. a pendulum's bobs) and write a GIF or an MP4.

    ``positions`` has shape (K, n_points, 2), or (K, n_points, 3) for points in space, drawn along the
    oblique view :data:`VIEW` (z up), and ``t`` length K.  With
    ``links=True`` segments join ``pivot`` and the points in order; each frame
    shows markers at the points and, with ``trail=True``, a fading trail of
    the last point over the preceding ``trail_time`` (s).  Frames are
    subsampled evenly in time to at most ``max_frames``.  ``path`` ending in
    ``.gif`` is written with Pillow; ``.mp4`` needs ffmpeg (``ValueError``
    otherwise).  The axes are fixed and equal-aspect; the window is
    :func:`view_window` of every position (and the pivot), so the bodies fill
    it.  ``pivot=None`` joins only the points (a rigid body's outline);
    ``ground`` (an (M, 2) polyline, e.g. the floor or a bowl, as long as
    wanted) is drawn clipped to the window.  The figure is
    :class:`PointsAnimation`: 640 px wide at the default ``dpi``, the time
    stamped in each frame.  Returns ``path``.
    """
    writer = _writer(path, fps)
    if fps <= 0:
        raise ValueError("animate_points: fps must be positive")
    anim = PointsAnimation(positions, t, trail=trail, max_frames=max_frames, links=links, pivot=pivot,
                           title=title, trail_time=trail_time, dpi=dpi, ground=ground)
    with writer.saving(anim.fig, str(path), dpi=anim.dpi):
        for i in anim.frames:
            writer.grab_rgba(anim.render(i))
    return str(path)


_BOX_EDGES = [(0, 1), (1, 2), (2, 3), (3, 0), (4, 5), (5, 6), (6, 7), (7, 4), (0, 4), (1, 5), (2, 6), (3, 7)]


def animate_rigid_body(t, rotations, path: str, size, momentum=None, center=None, fps: int = 20,
                       max_frames: int = 150, title: Optional[str] = None, dpi: int = ANIMATION_DPI,
                       surface=None) -> str:
    """Animate a box tumbling in 3-D (matplotlib's mplot3d) and write a GIF or an MP4.

    ``rotations`` (K, 3, 3) are the body-to-space rotations at times ``t``; the box has edges
    ``size`` along the body axes, centred at ``center`` (K, 3; the origin by default).  The body
    axes are drawn from the centre (red, green, blue for 1, 2, 3) and ``momentum`` (a fixed
    spatial vector, e.g. the angular momentum) as a black arrow.  ``surface`` ``(X, Y, Z)`` (2-D
    arrays) is drawn as a fixed wireframe, e.g. the ground under the body.  Frames are subsampled
    evenly in time to at most ``max_frames``; each is ``ANIMATION_WIDTH_IN * dpi`` pixels square (640
    by default) with the time stamped in its corner.  Returns ``path``.
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    writer = _writer(path, fps)
    t = _as_time(t, "animate_rigid_body")
    R = np.asarray(rotations, float)
    if R.shape != (t.size, 3, 3) or not np.all(np.isfinite(R)):
        raise ValueError(f"animate_rigid_body: rotations must be finite with shape ({t.size}, 3, 3)")
    C = np.zeros((t.size, 3)) if center is None else np.asarray(center, float).reshape(t.size, 3)
    half = 0.5 * np.asarray(size, float).reshape(3)
    signs = np.array([(-1, -1, -1), (1, -1, -1), (1, 1, -1), (-1, 1, -1),
                      (-1, -1, 1), (1, -1, 1), (1, 1, 1), (-1, 1, 1)], float)
    corners = signs * half
    frames = _frames(t, max_frames)
    # the window follows the body (its corners and drawn axes at every frame, and the origin the
    # momentum arrow starts from), as in animate_points; the surface is clipped to it
    tips = np.concatenate([corners, np.diag(half * 1.4), -np.diag(half * 1.4)])
    moving = (C[frames, None, :] + np.einsum("kij,mj->kmi", R[frames], tips)).reshape(-1, 3)
    if momentum is not None:
        moving = np.vstack([moving, np.zeros(3)])
    lo, hi = view_window(moving, cube=True)
    side = 2 * round(ANIMATION_WIDTH_IN * dpi / 2) / dpi  # square, even pixels
    fig = Figure(figsize=(side, side), dpi=dpi)
    canvas = FigureCanvasAgg(fig)
    ax = fig.add_subplot(projection="3d")
    if surface is not None:
        X, Y, Z = (np.asarray(a, float) for a in surface)
        inside = (X >= lo[0]) & (X <= hi[0]) & (Y >= lo[1]) & (Y <= hi[1]) & (Z >= lo[2]) & (Z <= hi[2])
        ax.plot_wireframe(X, Y, np.where(inside, Z, np.nan), color="0.7", lw=0.5, rstride=1, cstride=1)
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.set_zlim(lo[2], hi[2])
    ax.set_box_aspect((1, 1, 1))
    ax.tick_params(labelsize=6)
    if title:
        ax.set_title(title, fontsize=9)
    # the box, its axes and the time are animated: drawn over the static background each frame (blitting)
    edge_lines = [ax.plot([], [], [], "-", color="0.25", lw=1.2, animated=True)[0] for _ in _BOX_EDGES]
    axis_lines = [ax.plot([], [], [], "-", color=c, lw=2.0, animated=True)[0] for c in ("C3", "C2", "C0")]
    if momentum is not None:
        Lv = np.asarray(momentum, float).reshape(3)
        u = Lv / max(float(np.linalg.norm(Lv)), 1e-300)
        with np.errstate(divide="ignore", invalid="ignore"):  # the longest arrow from the origin in the window
            room = np.where(u > 0, hi / u, np.where(u < 0, lo / u, np.inf))
        Lv = u * 0.9 * float(np.min(room))
        ax.plot([0, Lv[0]], [0, Lv[1]], [0, Lv[2]], "-", color="k", lw=1.5)
        ax.text(Lv[0], Lv[1], Lv[2], "L", fontsize=8)
    stamp = ax.text2D(0.02, 0.95, "", transform=ax.transAxes, fontsize=9, animated=True)
    canvas.draw()
    background = canvas.copy_from_bbox(fig.bbox)
    with writer.saving(fig, str(path), dpi=dpi):
        for i in frames:
            P = C[i] + corners @ R[i].T
            for line, (a, b) in zip(edge_lines, _BOX_EDGES):
                line.set_data_3d([P[a, 0], P[b, 0]], [P[a, 1], P[b, 1]], [P[a, 2], P[b, 2]])
            for k, line in enumerate(axis_lines):
                tip = C[i] + R[i][:, k] * half[k] * 1.4
                line.set_data_3d([C[i, 0], tip[0]], [C[i, 1], tip[1]], [C[i, 2], tip[2]])
            stamp.set_text(time_stamp(t[i]))
            canvas.restore_region(background)
            for artist in (*edge_lines, *axis_lines, stamp):
                ax.draw_artist(artist)
            writer.grab_rgba(np.array(canvas.buffer_rgba()))
    return str(path)
