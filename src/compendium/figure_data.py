"""What a figure draws, as data: the arrays of its artists, axis by axis, read back from matplotlib.

:meth:`compendium.outputs.Outputs.figure` writes it beside the PNG and PDF as ``figures/data/<name>.json``, and
:mod:`compendium.guard` compares a fresh figure with the committed one through it, under the classes of
:mod:`compendium.contract`: a curve moved by 1 % is a difference on every machine, while PNG and PDF bytes,
which depend on the machine's last bits and fonts, are compared only for a note.

Per axes: the title, axis labels and scales, the limits, the legend's texts, free texts, and every artist with
its coordinates: lines (``x``, ``y`` and, in 3-D, ``z``), collections (scatter offsets or path vertices as ``x``,
``y``; colour-mapped values as ``c``), patches (bars: their corners) and images (``c``). Numbers are kept to
nine significant digits, far finer than any class compares.
"""

from __future__ import annotations

import json
import math

import numpy as np

FORMAT = 1
_DIGITS = 9


def _numbers(values) -> list:
    out = []
    for v in np.asarray(values, dtype=float).ravel():
        out.append(None if not math.isfinite(v) else float(f"{v:.{_DIGITS}g}"))
    return out


def _text(artist) -> str:
    return artist.get_text() if artist is not None else ""


def _axes_of_colorbar(ax) -> bool:
    return getattr(ax, "_colorbar", None) is not None or ax.get_label() == "<colorbar>"


def _line(line) -> dict:
    entry = {"type": "line", "label": _label(line)}
    if hasattr(line, "get_data_3d"):
        x, y, z = line.get_data_3d()
        entry |= {"x": _numbers(x), "y": _numbers(y), "z": _numbers(z)}
    else:
        x, y = line.get_data(orig=False)
        entry |= {"x": _numbers(_as_float(x)), "y": _numbers(_as_float(y))}
    return entry


def _as_float(values):
    try:
        return np.asarray(values, dtype=float)
    except (TypeError, ValueError):
        return np.full(np.shape(values), np.nan)


def _label(artist) -> str:
    label = artist.get_label() or ""
    return "" if label.startswith("_") else label


def _collection(collection) -> dict:
    entry = {"type": "collection", "label": _label(collection)}
    offsets = np.asarray(collection.get_offsets(), dtype=float)
    if hasattr(collection, "_offsets3d"):
        xs, ys, zs = (np.asarray(v, dtype=float) for v in collection._offsets3d)
        entry |= {"x": _numbers(xs), "y": _numbers(ys), "z": _numbers(zs)}
    elif offsets.size and not (offsets.shape[0] == 1 and np.allclose(offsets, 0.0)):
        entry |= {"x": _numbers(offsets[:, 0]), "y": _numbers(offsets[:, 1])}
    else:
        vertices = [np.asarray(p.vertices, dtype=float) for p in collection.get_paths()]
        vertices = np.concatenate(vertices) if vertices else np.zeros((0, 2))
        entry |= {"x": _numbers(vertices[:, 0]), "y": _numbers(vertices[:, 1])}
    values = collection.get_array()
    if values is not None:
        entry["c"] = _numbers(np.ma.filled(np.ma.asarray(values, dtype=float), np.nan))
    return entry


def _patch(patch) -> dict:
    vertices = np.asarray(patch.get_path().vertices, dtype=float)
    vertices = patch.get_patch_transform().transform(vertices) if hasattr(patch, "get_patch_transform") else vertices
    return {"type": "patch", "label": _label(patch), "x": _numbers(vertices[:, 0]), "y": _numbers(vertices[:, 1])}


def _image(image) -> dict:
    values = np.ma.filled(np.ma.asarray(image.get_array(), dtype=float), np.nan)
    return {"type": "image", "label": _label(image), "c": _numbers(values), "shape": list(values.shape)}


def _axes(ax) -> dict:
    three_d = hasattr(ax, "get_zlim")
    legend = ax.get_legend()
    entry = {
        "title": ax.get_title(),
        "xlabel": ax.get_xlabel(),
        "ylabel": ax.get_ylabel(),
        "xscale": ax.get_xscale(),
        "yscale": ax.get_yscale(),
        "xlim": _numbers(ax.get_xlim()),
        "ylim": _numbers(ax.get_ylim()),
        "legend": [t.get_text() for t in legend.get_texts()] if legend is not None else [],
        "texts": [t.get_text() for t in ax.texts],
        "colorbar": _axes_of_colorbar(ax),
    }
    if three_d:
        entry |= {"zlabel": ax.get_zlabel(), "zscale": ax.get_zscale(), "zlim": _numbers(ax.get_zlim())}
    artists = [_line(line) for line in ax.get_lines()]
    artists += [_collection(c) for c in ax.collections]
    artists += [_patch(p) for p in ax.patches]
    artists += [_image(i) for i in ax.images]
    entry["artists"] = artists
    return entry


def figure_data(fig) -> dict:
    """The figure's drawn data (the module docstring), JSON-ready."""
    suptitle = getattr(fig, "_suptitle", None)
    return {"format": FORMAT, "suptitle": _text(suptitle), "axes": [_axes(ax) for ax in fig.axes]}


def write_figure_data(fig, path) -> None:
    """``figure_data(fig)`` as JSON, one line per axes and per artist (so that a diff names what moved)."""
    data = figure_data(fig)

    def dump(obj) -> str:
        return json.dumps(obj, separators=(",", ":"), allow_nan=False)

    axes = []
    for ax in data["axes"]:
        head = dump({k: v for k, v in ax.items() if k != "artists"})[:-1]
        artists = ",\n".join(dump(a) for a in ax["artists"])
        axes.append(f'{head},"artists":[\n{artists}]}}' if artists else f'{head},"artists":[]}}')
    text = f'{{"format":{data["format"]},"suptitle":{dump(data["suptitle"])},"axes":[\n' + ",\n".join(axes) + "]}\n"
    with open(path, "w") as f:
        f.write(text)
