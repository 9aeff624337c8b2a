"""An animated GIF of a simulation seen from the side: x (m) to the right, z (m) up, looking
along +y. The pool's box, its water and every sphere as a circle of its true radius in the
colour of its RViz marker, so the GIF, RViz and Foxglove agree.

    python -m pool_sim.headless --animate pool.gif [--seconds 10] [--fps 20]

matplotlib is imported inside the functions that draw: the node never pays for it. Without
it, --animate is refused in one line naming the install command, before any simulating.
"""
import os
from pathlib import Path

import numpy as np

from pool_sim.physics import InvalidInput, Simulation
from pool_sim.ros.messages import sphere_colours, WATER_RGBA, water_top

WIDTH_PX = 480
DPI = 100  # pixels per inch: with it, font sizes in points give ~11 px text
LABELLED_SPHERES = 6  # the first spheres are named beside their circle; more would clutter
MARGIN_M_PER_M = 0.03  # room around the pool's box, as a share of its largest side
POOL_EDGE_RGB = (0.25, 0.25, 0.25)
SPHERE_EDGE_RGB = (0.1, 0.1, 0.1)


INSTALL_COMMAND = 'pip install matplotlib==3.11.2'


def require_matplotlib():
    """Refused (InvalidInput naming the install command) unless matplotlib imports."""
    try:
        import matplotlib  # noqa: F401
    except ImportError as error:
        raise InvalidInput(f'--animate needs matplotlib ({error}); install it with '
                           f'`{INSTALL_COMMAND}`') from None


# More frames than a GIF anyone would watch (40 min at 20 fps): refused before drawing.
MAX_FRAMES = 50_000


def checked_animation(path, seconds: float, fps: float) -> Path:
    """The path an animation will be written to, refused (InvalidInput naming it) unless it
    ends in .gif and can be written now; seconds >= 0 and fps > 0 (both finite). Checked
    before any simulating; so is a missing matplotlib."""
    require_matplotlib()
    if not (np.isfinite(seconds) and seconds >= 0.0):
        raise InvalidInput(f'--seconds: must be finite and >= 0, got {seconds!r}')
    if not (np.isfinite(fps) and fps > 0.0):
        raise InvalidInput(f'--fps: must be finite and > 0, got {fps!r}')
    if seconds * fps > MAX_FRAMES:
        raise InvalidInput(f'--seconds {seconds:g} at --fps {fps:g} is {seconds * fps:.3g} '
                           f'frames; at most {MAX_FRAMES} (a GIF of minutes, not of days)')
    path = Path(path)
    if path.suffix.lower() != '.gif':
        raise InvalidInput(f'--animate {path}: must end in .gif (an animated GIF is written)')
    if not path.parent.is_dir():
        raise InvalidInput(f'--animate {path}: no folder {path.parent}')
    existed = path.exists()
    try:
        # Opened, not asked (os.access): root passes every permission check but still
        # cannot write to a read-only file system.
        with open(path, 'ab'):
            pass
    except OSError as error:
        raise InvalidInput(f'--animate {path}: cannot write there ({error.strerror})') \
            from None
    if not existed:
        os.unlink(path)
    return path


def frame_times(seconds: float, fps: float) -> np.ndarray:
    """Simulated times (s) of the frames: 0, 1/fps, ... up to `seconds`, both ends drawn."""
    return np.arange(round(seconds * fps) + 1) / fps


class SideView:
    """A matplotlib figure of the pool seen from the side; draw(sim) updates it to sim's
    spheres and time. pixel_of(x, z) says where a point (m) lands in a saved frame."""

    def __init__(self, scene, count: int):
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.collections import EllipseCollection
        from matplotlib.figure import Figure
        from matplotlib.patches import Rectangle

        low, high = np.array(scene['pool.min'], float), np.array(scene['pool.max'], float)
        margin = MARGIN_M_PER_M * max(high[0] - low[0], high[2] - low[2])
        # Three margins above: room for the name of a sphere dropped from the ceiling.
        top_m = high[2] + 3 * margin
        width_m, height_m = high[0] - low[0] + 2 * margin, top_m - low[2] + margin
        # Room for the tick labels below and left of the pool and the clock above it; the
        # height follows the pool's aspect, within bounds, so a long flat pool stays readable.
        left_px, right_px, bottom_px, top_px = 50, 10, 40, 22
        plot_px = WIDTH_PX - left_px - right_px
        height_px = bottom_px + top_px + int(np.clip(plot_px * height_m / width_m, 100,
                                                     2 * WIDTH_PX))
        self.figure = Figure(figsize=(WIDTH_PX / DPI, height_px / DPI), dpi=DPI)
        FigureCanvasAgg(self.figure)
        self.axes = self.figure.add_axes([left_px / WIDTH_PX, bottom_px / height_px,
                                          plot_px / WIDTH_PX,
                                          1 - (bottom_px + top_px) / height_px])
        axes = self.axes
        axes.set_xlim(low[0] - margin, high[0] + margin)
        axes.set_ylim(low[2] - margin, top_m)
        axes.set_aspect('equal', adjustable='box', anchor='C')
        axes.tick_params(labelsize=7, length=2, pad=1)
        axes.set_xlabel('x [m]', fontsize=7, labelpad=1)
        axes.set_ylabel('z [m]', fontsize=7, labelpad=1)
        top = water_top(low, high, scene['water.surface_z'])
        axes.add_patch(Rectangle((low[0], low[2]), high[0] - low[0], top - low[2],
                                 facecolor=WATER_RGBA[:3], alpha=WATER_RGBA[3],
                                 edgecolor='none', zorder=1))
        axes.add_patch(Rectangle((low[0], low[2]), high[0] - low[0], high[2] - low[2],
                                 facecolor='none', edgecolor=POOL_EDGE_RGB, linewidth=1.5,
                                 zorder=2))
        self.colours = sphere_colours(count)[:, :3]
        # One collection for all spheres: widths in data units (m), so a circle's size is
        # its true diameter at any zoom.
        self.spheres = EllipseCollection(
            np.zeros(count), np.zeros(count), np.zeros(count), units='xy',
            offsets=np.zeros((count, 2)), offset_transform=axes.transData,
            facecolors=self.colours, edgecolors=SPHERE_EDGE_RGB, linewidths=0.5, zorder=3)
        axes.add_collection(self.spheres)
        self.labels = [axes.text(0, 0, '', fontsize=7, ha='center', va='bottom', zorder=4)
                       for _ in range(min(count, LABELLED_SPHERES))]
        self.clock = axes.set_title('', loc='left', fontsize=8, family='monospace', pad=4)
        axes.set_title('side view, looking along +y', loc='right', fontsize=7, pad=4)

    def draw(self, sim: Simulation):
        spheres = sim.spheres
        x, y, z = spheres.position
        # Looking along +y: the nearest sphere (smallest y) is drawn last, on top.
        order = np.argsort(-y, kind='stable')
        diameters = 2.0 * spheres.radius[order]
        self.spheres.set_offsets(np.column_stack((x[order], z[order])))
        self.spheres.set_widths(diameters)
        self.spheres.set_heights(diameters)
        self.spheres.set_facecolors(self.colours[order])
        for index, label in enumerate(self.labels):
            label.set_text(spheres.names[index])
            label.set_position((x[index], z[index] + spheres.radius[index] * 1.2))
        self.clock.set_text(f't = {sim.time:5.2f} s')

    def pixel_of(self, x_m: float, z_m: float) -> tuple:
        """(column, row) of the point (x, z) m in a saved frame, row 0 at the top."""
        self.axes.apply_aspect()  # what drawing does first: the axes' box for equal aspect
        column, up = self.axes.transData.transform((x_m, z_m))
        height_px = self.figure.get_size_inches()[1] * DPI
        return int(column), int(height_px - up)


def write_gif(scene, path, seconds: float, fps: float) -> Simulation:
    """Simulate `scene` for `seconds` s and write a frame every 1/fps s to `path` (a GIF,
    PillowWriter; no display needed). Returns the simulation at its last frame.

    A GIF holds each frame's delay in 1/100 s (Pillow truncates 1000/fps ms to it): fps
    that divide 100 (10, 20, 25, 50) play back in real time."""
    from matplotlib.animation import PillowWriter

    path = checked_animation(path, seconds, fps)
    sim = Simulation(scene)
    view = SideView(scene, sim.spheres.count)
    writer = PillowWriter(fps=fps)
    with writer.saving(view.figure, str(path), DPI):
        for time_s in frame_times(seconds, fps):
            sim.advance(time_s - sim.time)
            view.draw(sim)
            writer.grab_frame()
    return sim
