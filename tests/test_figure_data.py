"""What a figure draws, read back from its artists (compendium.figure_data): what the guard compares."""

import json

import matplotlib.pyplot as plt
import numpy as np

from compendium import plotting
from compendium.figure_data import figure_data, write_figure_data


def test_lines_scatter_bars_images_texts_and_scales_are_read_back(tmp_path):
    fig, (a, b, c) = plt.subplots(1, 3)
    a.semilogy([1, 2, 4], [1e-3, 1e-6, np.nan], "o-", label="error")
    a.axhline(1e-9, label="floor")
    a.set_title("t_f = 0.4466")
    a.legend()
    image = b.scatter([1.0, 2.0], [3.0, 4.0], c=[5365.4, 5400.1])
    fig.colorbar(image, ax=b, label="fuel (kg)")
    b.text(1.5, 3.5, "nominal")
    c.bar([0, 1], [2.0, 3.0])
    c.imshow(np.arange(6.0).reshape(2, 3))
    fig.suptitle("a figure")
    data = figure_data(fig)
    plt.close(fig)
    assert data["suptitle"] == "a figure" and len(data["axes"]) == 4  # the colorbar is an axes too
    first = data["axes"][0]
    assert first["yscale"] == "log" and first["title"] == "t_f = 0.4466" and first["legend"] == ["error", "floor"]
    line, floor = first["artists"]
    assert line["x"] == [1.0, 2.0, 4.0] and line["y"] == [1e-3, 1e-6, None] and floor["y"] == [1e-9, 1e-9]
    scatter = data["axes"][1]["artists"][0]
    assert scatter["type"] == "collection" and scatter["x"] == [1.0, 2.0] and scatter["c"] == [5365.4, 5400.1]
    assert data["axes"][1]["texts"] == ["nominal"] and data["axes"][-1]["colorbar"]
    kinds = [a["type"] for a in data["axes"][2]["artists"]]
    assert kinds == ["patch", "patch", "image"] and data["axes"][2]["artists"][1]["y"][2] == 3.0
    write_figure_data(plt.figure(), tmp_path / "f.json")
    assert json.loads((tmp_path / "f.json").read_text())["axes"] == []


def test_a_line_in_three_dimensions_keeps_its_z():
    fig = plt.figure()
    ax = fig.add_subplot(projection="3d")
    ax.plot([0.0, 1.0], [0.0, 2.0], [0.0, 3.0], label="track")
    data = figure_data(fig)
    plt.close(fig)
    (line,) = data["axes"][0]["artists"]
    assert line["z"] == [0.0, 3.0] and data["axes"][0]["zscale"] == "linear"


def test_numbers_are_kept_to_nine_significant_digits():
    fig, ax = plt.subplots()
    ax.plot([0.0, 1.0], [0.44664533379331, 1 / 3])
    (line,) = figure_data(fig)["axes"][0]["artists"]
    plt.close(fig)
    assert line["y"] == [0.446645334, 0.333333333]


def test_a_rounding_level_quantity_is_drawn_on_its_floor():
    fig, ax = plt.subplots()
    ax.semilogy([1, 2, 3], plotting.floored([3.6e-12, 3.3e-15, -1e-16], 1e-12))
    plotting.draw_floor(ax, 1e-12)
    curve, floor = figure_data(fig)["axes"][0]["artists"]
    plt.close(fig)
    assert curve["y"] == [3.6e-12, 1e-12, 1e-12] and floor["y"] == [1e-12, 1e-12]
