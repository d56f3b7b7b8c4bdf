"""``save_figure`` writes a PNG with one draw of the figure, and the same bytes as ``savefig``.

``Figure.savefig`` on a figure with constrained layout draws it twice: once with drawing
disabled to run the layout, once for the pixels. ``plots.save_figure`` runs the layout engine on
its own at the file's resolution and saves with the layout off (issue 29, session 13). The truth
is matplotlib's own ``savefig`` of an identical figure: the files must be byte for byte equal, on
every figure kind of the catalogue's shapes and at another resolution than the figure's.
"""

from __future__ import annotations

import dataclasses

import pytest
from matplotlib.figure import Figure

from adaptive_ftc import plots
from tests.test_figure_layout import _FIGURES, _result_for


def _one_per_kind() -> list[tuple[str, dict]]:
    seen: dict[str, tuple[str, dict]] = {}
    for name, spec in _FIGURES:
        seen.setdefault(spec["kind"], (name, spec))
    return list(seen.values())


def _figure(name: str, spec: dict):
    r = _result_for(name, spec)
    kwargs = {}
    if spec["kind"] == "tracking":
        kwargs["baselines"] = {"frozen adaptation": dataclasses.replace(r, status="diverged")}
    return r, kwargs


def _savefig_png(r, spec: dict, kwargs: dict, path, dpi: int) -> bytes:
    """The file matplotlib's own savefig writes for the figure save_figure draws."""
    number, caption = spec.get("number"), str(spec.get("caption", "")).strip()
    title = f"Fig. {number}: {caption}" if number not in (None, "") else caption or None
    fp = plots.plot(r, spec["kind"], outputs=spec.get("outputs"), title=title, **kwargs)
    with plots.figure_style():
        fp.figure.savefig(
            path,
            dpi=dpi,
            format="png",
            metadata=plots._metadata("png", title),
            pil_kwargs={"compress_level": plots.PNG_COMPRESS},
        )
    return path.read_bytes()


_KINDS = _one_per_kind()


@pytest.mark.parametrize(("name", "spec"), _KINDS, ids=[s["kind"] for _, s in _KINDS])
@pytest.mark.parametrize("dpi", [None, 72])
def test_a_png_is_the_file_savefig_writes(name, spec, dpi, tmp_path):
    r, kwargs = _figure(name, spec)
    ours = plots.save_figure(r, spec, tmp_path / "ours.png", dpi=dpi, **kwargs)
    truth = _savefig_png(r, spec, kwargs, tmp_path / "truth.png", dpi or plots.DPI)
    assert ours.read_bytes() == truth


def test_a_png_is_drawn_once(monkeypatch, tmp_path):
    name, spec = _KINDS[0]
    r, kwargs = _figure(name, spec)
    draws = []
    real_draw = Figure.draw

    def counting_draw(self, renderer):
        draws.append(renderer)
        return real_draw(self, renderer)

    monkeypatch.setattr(Figure, "draw", counting_draw)
    plots.save_figure(r, spec, tmp_path / "f.png", **kwargs)
    assert len(draws) == 1
    # the layout is still the figure's: a later savefig lays it out again
    plots.save_figure(r, spec, tmp_path / "g.png", formats=("png", "pdf"), **kwargs)
    assert (tmp_path / "g.png").read_bytes() == (tmp_path / "f.png").read_bytes()


def test_a_matplotlibrc_savefig_colour_still_applies(tmp_path):
    import matplotlib

    name, spec = _KINDS[0]
    r, kwargs = _figure(name, spec)
    with matplotlib.rc_context({"savefig.facecolor": "yellow"}):
        ours = plots.save_figure(r, spec, tmp_path / "ours.png", **kwargs)
        truth = _savefig_png(r, spec, kwargs, tmp_path / "truth.png", plots.DPI)
    assert ours.read_bytes() == truth
    assert truth != plots.save_figure(r, spec, tmp_path / "plain.png", **kwargs).read_bytes()
