"""The grasp picture: the HTML page (drawn by a real headless browser), the PNG, the command."""

from __future__ import annotations

import re
import shutil
import subprocess
import sys

import numpy as np
import pytest

import exactgrasp as eg
from exactgrasp.cli.main import main
from exactgrasp.errors import MissingDependencyError, SamplerError
from exactgrasp.view.scene import OBJECT_NAME, build_scene

pytest.importorskip("plotly", reason="plotly is in the 'view' extra")
Image = pytest.importorskip("PIL.Image", reason="Pillow comes with matplotlib")

BROWSERS = ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable")


def can_grasp() -> eg.Grasp:
    """The built-in Barrett hand with a can lying across the palm, just clear of the knuckles."""
    pose = np.array([[0.0, 0, 1, 0], [0, 1, 0, 0], [-1, 0, 0, 0.128], [0, 0, 0, 1]])
    return eg.Grasp(eg.hands.barrett(), eg.objects.cylinder(), pose, name="can")


@pytest.fixture(scope="module")
def grasp():
    return can_grasp()


@pytest.fixture(scope="module")
def shown(grasp, tmp_path_factory):
    out = tmp_path_factory.mktemp("view")
    return eg.show(grasp, n_paths=24, path=out / "grasp.html", png=out / "grasp.png")


def figure_of(scene):
    from exactgrasp.view.html import figure

    return figure(scene)


def colours(path):
    """(distinct colours, fraction of pixels that are not near-white, RGB array)."""
    rgb = np.asarray(Image.open(path).convert("RGB")).astype(np.int64)
    flat = rgb.reshape(-1, 3)
    distinct = len(np.unique(flat[:, 0] << 16 | flat[:, 1] << 8 | flat[:, 2]))
    not_white = float(np.mean(flat.min(axis=1) < 235))
    return distinct, not_white, rgb


def drawn(rgb) -> tuple[float, float]:
    """Fractions of the pixels that are object orange and hand grey-blue (any shading)."""
    r, g, b = (rgb[..., c] for c in range(3))
    orange = np.mean((r > 150) & (r - b > 60) & (g > 70) & (g < r - 20))
    grey_blue = np.mean((b > r + 10) & (b - r < 60) & (b > 80) & (b < 225) & (g > r))
    return float(orange), float(grey_blue)


def test_html_is_one_self_contained_file(shown):
    text = shown.html.read_text()
    assert shown.html.stat().st_size > 1_000_000, "plotly.js is not embedded"
    remote = re.findall(r"<script[^>]*\bsrc\s*=\s*[\"']?(?:https?:)?//", text, re.IGNORECASE)
    assert not remote, f"the page loads scripts from the network: {remote}"
    assert not re.search(r"<link[^>]*href\s*=\s*[\"']?https?://", text, re.IGNORECASE)
    assert "Plotly.newPlot" in text


def test_every_link_the_object_axes_and_paths_are_traces(shown, grasp):
    names = [trace.name for trace in figure_of(shown.scene).data]
    text = shown.html.read_text()
    for name in [*grasp.hand.link_names, OBJECT_NAME, "x axis", "y axis", "z axis"]:
        assert name in names
        assert f'"name":"{name}"' in text, f"{name!r} is not in the written page"
    meshes = [t for t in figure_of(shown.scene).data if t.type == "mesh3d"]
    ghosts = [t for t in meshes if t.name.startswith("object at t=")]
    assert len(meshes) - len(ghosts) == len(grasp.hand.link_names) + 1
    assert sum(name.startswith("path ") for name in names) == 24


def test_axes_are_labelled_unit_segments_in_red_green_blue(shown):
    axes = {t.name: t for t in figure_of(shown.scene).data if t.name.endswith(" axis")}
    for k, (name, label, colour) in enumerate(
        [("x axis", "x", "#d62728"), ("y axis", "y", "#2ca02c"), ("z axis", "z", "#1f5fd6")]
    ):
        trace = axes[name]
        tip = np.array([trace.x[1], trace.y[1], trace.z[1]])
        np.testing.assert_allclose(tip, np.eye(3)[k])
        assert trace.line.color == colour and label in trace.text


@pytest.mark.parametrize("n_paths", [1, 7, 474])
def test_the_number_of_path_traces_is_n_paths(grasp, n_paths):
    scene = build_scene(grasp, "balanced", n_paths=n_paths)
    paths = [t for t in figure_of(scene).data if t.name.startswith("path ")]
    assert len(paths) == n_paths == len({p.index for p in scene.paths})


def test_paths_start_at_the_object_centre_and_are_coloured_by_time(grasp):
    scene = build_scene(grasp, {"n_translations": 4, "n_axes": 1, "n_amounts": 2}, n_paths=5)
    centre = grasp.frame.apply(grasp.object_pose[:3, :3] @ grasp.object.centroid + [0, 0, 0.128])
    sampler = eg.PathSampler(n_translations=4, n_axes=1, n_amounts=2)
    poses = sampler.poses()
    for part in scene.paths:
        np.testing.assert_allclose(part.points[0], centre, atol=1e-9)
        assert part.times[0] == 0.0 and np.all(np.diff(part.times) > 0)
        np.testing.assert_allclose(part.times[part.at_step], sampler.times)
        expected = poses[part.index, :, :3, :3] @ centre + poses[part.index, :, :3, 3]
        np.testing.assert_allclose(part.points[part.at_step], expected, atol=1e-9)
    first = next(t for t in figure_of(scene).data if t.name.startswith("path "))
    assert first.marker.showscale and first.marker.colorbar.title.text.startswith("time t")


def test_the_png_is_written_and_not_blank(shown):
    distinct, not_white, _ = colours(shown.png)
    assert distinct > 200 and not_white > 0.05, (distinct, not_white)


def test_show_reads_a_grasp_file_and_png_alone_needs_no_html(grasp, tmp_path):
    file = grasp.save(tmp_path / "can.json")
    result = eg.show(str(file), sampler="rotations", n_paths=3, path=None, png=tmp_path / "a.png")
    assert result.html is None and result.png.is_file()
    assert [m.name for m in result.scene.meshes] == [*grasp.hand.link_names, OBJECT_NAME]


@pytest.mark.parametrize(
    ("kwargs", "named"),
    [
        ({"n_paths": 0}, "n_paths"),
        ({"n_paths": -3}, "n_paths"),
        ({"n_paths": 2.5}, "n_paths"),
        ({"n_paths": 475}, "n_paths"),
        ({"sampler": "sideways"}, "sampler"),
        ({"sampler": "missing.json"}, "sampler"),
        ({"sampler": {"n_turns": 3}}, "sampler"),
        ({"steps": 0}, "steps"),
    ],
)
def test_bad_arguments_are_named(grasp, tmp_path, kwargs, named):
    with pytest.raises(SamplerError, match=named):
        eg.show(grasp, path=tmp_path / "g.html", **kwargs)
    assert not (tmp_path / "g.html").exists()


def test_missing_plotly_names_the_extra(grasp, tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "plotly", None)
    monkeypatch.setitem(sys.modules, "plotly.graph_objects", None)
    with pytest.raises(MissingDependencyError, match=r"plotly.*exactgrasp\[view\]"):
        eg.show(grasp, path=tmp_path / "g.html")


def test_command_writes_the_page_and_the_picture(grasp, tmp_path, capsys):
    file = grasp.save(tmp_path / "can.json")
    html, png = tmp_path / "out" / "can.html", tmp_path / "can.png"
    args = ["show", str(file), "-o", str(html), "--png", str(png), "--paths", "6"]
    assert main([*args, "--steps", "4", "--sampler", "translations"]) == 0
    assert html.is_file() and png.is_file()
    assert "6 of" in capsys.readouterr().out
    assert html.read_text().count('"name":"path ') == 6


@pytest.mark.parametrize(
    ("flags", "named"),
    [
        (["--paths", "0"], "--paths"),
        (["--sampler", "sideways"], "--sampler"),
        (["--sampler", "{not json"], "--sampler"),
        (["--steps", "0"], "--steps"),
    ],
)
def test_command_errors_name_the_flag(grasp, tmp_path, capsys, flags, named):
    file = grasp.save(tmp_path / "can.json")
    assert main(["show", str(file), "-o", str(tmp_path / "g.html"), *flags]) == 2
    err = capsys.readouterr().err
    assert err.startswith("exactgrasp show: error:") and named in err, err


def browser() -> str | None:
    return next((found for name in BROWSERS if (found := shutil.which(name))), None)


def screenshot(html, png, profile, size=(1000, 800)) -> subprocess.CompletedProcess:
    """Render a page in headless Chromium (software WebGL) and save what it shows."""
    command = [
        browser(),
        "--headless",
        "--no-sandbox",
        "--disable-dev-shm-usage",
        "--enable-unsafe-swiftshader",
        "--use-angle=swiftshader",
        "--hide-scrollbars",
        f"--user-data-dir={profile}",
        f"--window-size={size[0]},{size[1]}",
        # plotly draws after load; virtual time lets it finish without a fixed wait.
        "--virtual-time-budget=8000",
        f"--screenshot={png}",
        html.resolve().as_uri(),
    ]
    return subprocess.run(command, capture_output=True, text=True, timeout=90)


@pytest.mark.skipif(
    browser() is None, reason="no chromium to render the page (apt-get install chromium)"
)
def test_a_browser_draws_the_page(shown, tmp_path):
    png = tmp_path / "page.png"
    result = screenshot(shown.html, png, tmp_path / "profile")
    assert png.is_file(), result.stderr[-2000:]
    distinct, not_white, rgb = colours(png)
    # The object is orange, the links grey-blue; a page where WebGL failed has neither.
    orange, grey_blue = drawn(rgb)
    assert distinct > 500 and not_white > 0.1, (distinct, not_white)
    assert orange > 0.005, f"the object is not drawn ({orange:.4f} of the pixels are orange)"
    assert grey_blue > 0.01, f"the hand is not drawn ({grey_blue:.4f} of the pixels)"


@pytest.mark.skipif(browser() is None, reason="no chromium to render the page")
def test_the_blank_check_fails_on_a_page_without_webgl(tmp_path):
    """The browser test above would catch a page whose 3-D scene did not draw."""
    from exactgrasp.view.html import write_html

    scene = build_scene(can_grasp(), n_paths=2)
    html = write_html(scene, tmp_path / "g.html")
    png = tmp_path / "nogl.png"
    command = [browser(), "--headless", "--no-sandbox", "--disable-webgl", "--hide-scrollbars"]
    command += [f"--user-data-dir={tmp_path / 'p'}", "--window-size=1000,800"]
    command += ["--virtual-time-budget=4000", f"--screenshot={png}", html.as_uri()]
    subprocess.run(command, capture_output=True, timeout=90)
    orange, grey_blue = drawn(colours(png)[2])
    assert orange < 0.005 and grey_blue < 0.01


# -- descriptors as pictures ---------------------------------------------------------------------


def test_paths_are_ordered_by_kind_then_direction():
    from exactgrasp.view.descriptors import KIND_ORDER, path_order

    sampler = eg.PathSampler.preset("balanced")
    order = path_order(sampler)
    assert sorted(order) == list(range(sampler.n_paths))
    table = sampler.paths
    kinds = table.kind[order]
    ranks = [KIND_ORDER.index(k) for k in kinds]
    assert ranks == sorted(ranks)  # translations, rotations, both: each kind one block
    moves = table.direction[order][kinds == "translation"]
    elevation = np.arcsin(np.clip(moves[:, 2], -1, 1))
    assert np.all(np.diff(elevation) >= -1e-9)  # up the sphere of directions


def test_the_descriptor_figure_is_one_colour_scale_with_its_unit(tmp_path):
    """Two grasps by two 'backends' (the same values, one scaled): panels of paths x steps in
    path order, every image on the colour scale 0 .. the largest value of all."""
    import matplotlib.pyplot as plt

    from exactgrasp.view.descriptors import VALUE_LABEL, path_order, plot_descriptors

    sampler = eg.PathSampler(3, 2, 2, n_steps=4)
    values = np.arange(sampler.n_paths * 4, dtype=float).reshape(sampler.n_paths, 4) / 100
    made = {
        (grasp, backend): eg.Descriptor(values * scale, {"sampler": sampler.params})
        for grasp, scale0 in (("a", 1.0), ("b", 0.5))
        for backend, scale in (("voxel", scale0), ("exact", 2 * scale0))
    }
    fig = plot_descriptors(made)
    panels = [ax for ax in fig.axes if ax.images]
    assert [ax.get_title() for ax in panels] == ["a: voxel", "a: exact", "b: voxel", "b: exact"]
    top = float(values.max() * 2)
    assert all(ax.images[0].get_clim() == (0.0, top) for ax in panels)
    np.testing.assert_array_equal(panels[0].images[0].get_array(), values[path_order(sampler)])
    colour_bars = [ax for ax in fig.axes if ax.get_ylabel() == VALUE_LABEL]
    assert len(colour_bars) == 1
    path = tmp_path / "d.png"
    fig.savefig(path)
    plt.close(fig)
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_the_legend_has_one_entry_per_group_and_the_axes_give_millimetres(shown, grasp):
    fig = figure_of(shown.scene)
    entries = [t.name for t in fig.data if t.showlegend]
    kinds = {k: sum(p.kind == k for p in shown.scene.paths) for k in ("translation", "both")}
    n_links = len(grasp.hand.link_names)
    assert entries[:2] == [f"hand ({n_links} links)", "object"]
    assert "canonical frame axes" in entries and len(entries) <= 8
    assert (
        f"{kinds['both']} paths: both" in entries and f"{kinds['translation']} path" in entries[4]
    )
    assert not [t for t in fig.data if t.showlegend and t.name.startswith("path ")]
    assert fig.layout.legend.groupclick == "togglegroup"
    # One canonical unit is half the palm frame's depth: 42.5 mm for the Barrett hand.
    mm = 1000.0 / grasp.frame.scale
    assert mm == pytest.approx(42.5)
    assert fig.layout.scene.xaxis.title.text == "x (unit = 42.5 mm)"
    assert (
        "canonical frame: 1 unit = 42.5 mm (half the palm frame's depth)" in fig.layout.title.text
    )
    # The camera stands back further than plotly's default, so that the titles fit.
    eye = fig.layout.scene.camera.eye
    assert np.linalg.norm([eye.x, eye.y, eye.z]) > 2.2


def test_ghosts_show_the_object_turning_along_the_path_that_rotates_it_most(grasp):
    from exactgrasp.geometry.se3 import exp_se3
    from exactgrasp.view.scene import GHOST_FRACTIONS

    scene = build_scene(grasp, "balanced", n_paths=24)
    object_mesh = next(m for m in scene.meshes if m.role == "object")
    assert len(scene.ghosts) == len(GHOST_FRACTIONS)
    drawn = [p.index for p in scene.paths]
    sampler = eg.PathSampler.preset("balanced")
    amounts = np.abs(sampler.paths.amount[drawn])
    index = drawn[int(np.argmax(amounts))]
    assert all(g.name.endswith(f" on path {index}") for g in scene.ghosts)
    last = scene.ghosts[-1]
    t = float(sampler.times.max())
    pose = exp_se3(sampler.paths.omega[index] * t, sampler.paths.direction[index] * t)
    np.testing.assert_allclose(
        last.vertices, object_mesh.vertices @ pose[:3, :3].T + pose[:3, 3], atol=1e-12
    )
    # It turns: the copy is not the grasp's object shifted.
    shift = last.vertices.mean(axis=0) - object_mesh.vertices.mean(axis=0)
    assert np.abs(last.vertices - (object_mesh.vertices + shift)).max() > 0.05
