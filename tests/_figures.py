"""Seeing a figure the way a reader does: every legend entry must be visible in the image.

:func:`assert_legend_visible` renders a figure to RGBA pixels (matplotlib's Agg canvas, no
pyplot) and, for every entry of every legend, counts the pixels of the entry's colour in
the legend's axes outside the legend's own box. An element drawn under another one (the
green ``min V*`` line of Figure 4 below the dots), clipped away or drawn off the axes leaves
too few pixels of its colour and fails the check, whatever the artist tree says.

The colour an entry should show is its artist's colour composited over the axes' white
background with the artist's alpha (dots at ``alpha=0.7`` are a lighter blue). A thin line
is anti-aliased: across its width, its pixels mix its colour with the white behind it
(a 1.7-pixel line placed between pixel rows has no pixel of its full colour), so a pixel
counts when it is such a mixture with at least :data:`MIN_COVERAGE` of the colour. A
mixture with another element's colour (a line half hidden by dots) does not count. Two
entries whose colours cannot be told apart this way (the same colour, or one a paler mix
of the other) are refused unless the test names them in ``allow_shared``.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.colors import to_rgba
from matplotlib.figure import Figure
from matplotlib.legend import Legend

#: Largest per-channel difference (0-255) between a pixel and an entry's colour (or its
#: mixture with white) for the pixel to count as that colour: rendering and rounding stay
#: within a few units; tab10 colours differ from each other by 40 or more in some channel.
COLOUR_TOL = 24

#: Least share of an entry's colour (the rest white) for a pixel to count as that colour:
#: the middle of an anti-aliased line covers at least half of its pixel.
MIN_COVERAGE = 0.5

#: Default number of pixels of its colour an entry must have outside the legend: a single
#: 3.5-point marker at 100 dpi covers about 15 pixels at its full colour.
MIN_PIXELS = 12


@dataclass
class Entry:
    """One legend entry: its text, the colour it should show (RGB 0-255), and its legend."""

    label: str
    rgb: np.ndarray
    legend: Legend


def render(fig: Figure) -> np.ndarray:
    """The figure as an (H, W, 4) uint8 RGBA array, drawn by Agg at the figure's dpi."""
    canvas = fig.canvas if isinstance(fig.canvas, FigureCanvasAgg) else FigureCanvasAgg(fig)
    canvas.draw()
    return np.asarray(canvas.buffer_rgba()).copy()


def _handle_rgba(handle: object) -> tuple[float, float, float, float]:
    """The colour a legend handle draws with (line, marker, patch or collection)."""
    get = getattr
    if hasattr(handle, "get_linestyle") and hasattr(handle, "get_marker"):  # Line2D
        no_line = get(handle, "get_linestyle")() in ("None", "none", "", " ")
        if no_line:
            face = get(handle, "get_markerfacecolor")()
            c = get(handle, "get_markeredgecolor")() if _none(face) else face
        else:
            c = get(handle, "get_color")()
    elif hasattr(handle, "get_facecolor") and not hasattr(handle, "get_segments"):
        c = get(handle, "get_facecolor")()
        if _none(c) or np.asarray(to_rgba(np.atleast_2d(c)[0]))[3] == 0:
            c = get(handle, "get_edgecolor")()
    else:  # a LineCollection (errorbars, hlines)
        c = get(handle, "get_color")()
    first = c if isinstance(c, str) else np.atleast_2d(np.asarray(c, dtype=np.float64))[0]
    rgba = to_rgba(first)  # a name, an RGB or an RGBA: always four numbers
    alpha = get(handle, "get_alpha")()
    a = float(rgba[3]) * (1.0 if alpha is None else float(alpha))
    return float(rgba[0]), float(rgba[1]), float(rgba[2]), a


def _none(c: object) -> bool:
    return isinstance(c, str) and c.lower() == "none"


def entries(fig: Figure) -> list[Entry]:
    """Every entry of every legend of the figure (axes legends and figure legends)."""
    legends = [ax.get_legend() for ax in fig.axes if ax.get_legend() is not None]
    legends += list(fig.legends)
    out = []
    for leg in legends:
        for handle, text in zip(leg.legend_handles, leg.get_texts(), strict=True):
            r, g, b, a = _handle_rgba(handle)
            over_white = np.array([r, g, b]) * a + (1.0 - a)
            out.append(Entry(text.get_text(), np.round(255 * over_white), leg))
    return out


def _box(extents: np.ndarray, shape: tuple[int, ...], pad: int = 0) -> tuple[slice, slice]:
    """Rows and columns of the image covered by a display box (origin bottom left)."""
    h, w = shape[:2]
    x0, y0, x1, y1 = extents
    rows = slice(max(0, int(np.floor(h - y1)) - pad), min(h, int(np.ceil(h - y0)) + pad))
    cols = slice(max(0, int(np.floor(x0)) - pad), min(w, int(np.ceil(x1)) + pad))
    return rows, cols


def colour_pixels(fig: Figure, entry: Entry, image: np.ndarray | None = None) -> int:
    """Pixels of ``entry``'s colour inside its legend's axes and outside the legend box."""
    img = render(fig) if image is None else image
    renderer = fig.canvas.get_renderer()
    parent = entry.legend.axes
    area = parent.get_window_extent(renderer) if parent is not None else fig.bbox
    mask = np.zeros(img.shape[:2], dtype=bool)
    mask[_box(area.extents, img.shape)] = True
    mask[_box(entry.legend.get_window_extent(renderer).extents, img.shape, pad=2)] = False
    return int((_of_colour(img[..., :3], entry.rgb) & mask).sum())


def _of_colour(pixels: np.ndarray, rgb: np.ndarray) -> np.ndarray:
    """Which pixels (RGB 0-255, any shape ending in 3) are ``rgb`` mixed with white, with
    at least ``MIN_COVERAGE`` of ``rgb``, each channel within ``COLOUR_TOL``."""
    p = np.asarray(pixels, dtype=np.float64)
    white = np.full(3, 255.0)
    d = np.asarray(rgb, dtype=np.float64) - white
    dd = float(d @ d)
    t = ((p - white) @ d) / dd if dd > 0 else np.ones(p.shape[:-1])
    t = np.clip(t, MIN_COVERAGE, 1.0)  # the nearest admissible mixture
    mix = white + t[..., None] * d
    return np.abs(p - mix).max(axis=-1) <= COLOUR_TOL


def assert_legend_visible(
    fig: Figure,
    *,
    min_pixels: int = MIN_PIXELS,
    allow_shared: Iterable[str] = (),
    expect: Iterable[str] = (),
) -> dict[str, int]:
    """Every legend entry's colour shows in at least ``min_pixels`` pixels of its axes
    outside the legend; returns the count per label.

    ``allow_shared`` names entries that may share a colour with another (the check then
    cannot tell them apart); ``expect`` names labels (prefixes) that must be in a legend.
    """
    found = entries(fig)
    assert found, "the figure has no legend entry"
    labels = [e.label for e in found]
    for want in expect:
        assert any(lab.startswith(want) for lab in labels), f"no legend entry {want!r}: {labels}"
    shared = set(allow_shared)
    for i, a in enumerate(found):
        for b in found[i + 1 :]:
            alike = bool(_of_colour(a.rgb, b.rgb) or _of_colour(b.rgb, a.rgb))
            same = a.legend is b.legend and alike
            if same and not ({a.label, b.label} & shared):
                raise AssertionError(
                    f"legend entries {a.label!r} and {b.label!r} share a colour: pixels "
                    "cannot tell whether each is visible"
                )
    image = render(fig)
    counts = {e.label: colour_pixels(fig, e, image) for e in found}
    hidden = {k: v for k, v in counts.items() if v < min_pixels}
    assert not hidden, f"legend entries not visible (pixels of their colour): {hidden}"
    return counts
