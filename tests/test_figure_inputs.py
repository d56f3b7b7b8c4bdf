"""What a figure worker is sent, and the mathtext parses the figures of a process share.

Issue 29 (session 14): ``aftc reproduce`` sent each figure worker the whole run (45 MB for a
120 s run recorded every millisecond) and every baseline, although :func:`plots.plot` draws a
thinned copy and only tracking figures draw the baselines; :func:`plots.figure_input` is what the
figure draws. Every Agg figure parsed its math text again (a new renderer, a new parser);
:func:`plots.save_figure` now gives its renderer the process's one cached parser. The truth for
both is the PNG the figure gives without them: the bytes must be equal.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from adaptive_ftc import plots
from adaptive_ftc.sim.result import SimResult
from tests.test_figure_layout import _result_for, _synthetic


def _long_run(n: int = 24_001) -> SimResult:
    """A long record with a chattering command (what 1 ms records of the catalogue hold)."""
    r = _synthetic(("alpha",), ("delta_e", "delta_c"), n=n, t_final=120.0)
    chatter = np.where(np.arange(n) % 3 == 0, 1.0, -1.0)[:, None] * np.array([[2.0, -1.5]])
    return dataclasses.replace(r, u_cmd=r.u_cmd + chatter, u_applied=r.u_applied + chatter)


def _png(result: SimResult, spec: dict, path, **kwargs) -> bytes:
    return plots.save_figure(result, spec, path, **kwargs).read_bytes()


@pytest.mark.parametrize("kind", ["tracking", "control", "parameters", "control_parameters"])
def test_a_figure_of_its_input_is_the_figure_of_the_run(kind, tmp_path):
    r = _long_run()
    spec = {"kind": kind, "caption": f"a long run: {kind}"}
    drawn = plots.figure_input(r, kind)
    assert drawn.time.size <= plots._MAX_POINTS < r.time.size
    assert drawn.time[-1] == r.time[-1]  # the last sample is drawn
    kwargs, drawn_kwargs = {}, {}
    if kind == "tracking":
        base = dataclasses.replace(r, status="diverged")
        kwargs = {"baselines": {"frozen adaptation": base}}
        drawn_kwargs = {"baselines": {"frozen adaptation": plots.figure_input(base, kind)}}
    assert _png(drawn, spec, tmp_path / "drawn.png", **drawn_kwargs) == _png(
        r, spec, tmp_path / "run.png", **kwargs
    )


def test_a_direction_figure_gets_the_whole_run():
    r = _long_run()
    assert plots.figure_input(r, "direction") is r  # its zoom reads the whole record


def test_a_run_that_thinning_twice_would_change_is_sent_whole():
    # 8000 samples thin to 4001 (every 2nd, then the last), which plot() would thin again
    r = _long_run(8000)
    assert plots._thin(plots._thin(r)) is not plots._thin(r)
    assert plots.figure_input(r, "control") is r
    short = _long_run(1000)
    assert plots.figure_input(short, "control") is short


def test_reproduce_sends_the_figure_workers_what_the_figures_draw(tmp_path):
    from adaptive_ftc import reproduce

    r = _long_run()
    thesis = dataclasses.replace(r, status="completed")

    class Recorder:
        def __init__(self):
            self.calls = []

        def submit(self, fn, *args):
            self.calls.append(args)
            return None

    class Scenario:
        name = "long"
        figures = ()
        title = "long"

    specs = [{"kind": k, "caption": k} for k in ("tracking", "control", "parameters")]
    plan = {"long": [(s, f"fig_{s['kind']}.png") for s in specs]}
    results = {("long", "adaptive"): {"result": r}, ("long", "thesis_law"): {"result": thesis}}
    executor = Recorder()
    new = reproduce._submit_figures(executor, Scenario(), plan, results, tmp_path)
    assert len(new) == 3
    sent = {args[1]["kind"]: args for args in executor.calls}
    for kind, (result, _spec, _path, baselines, *_rest) in sent.items():
        assert result.time.size <= plots._MAX_POINTS, kind
        if kind == "tracking":
            assert list(baselines) == [reproduce._BASELINE_LABELS["thesis_law"]]
            assert all(b.time.size <= plots._MAX_POINTS for b in baselines.values())
        else:
            assert baselines == {}, kind  # only tracking figures draw the baselines


def test_figures_share_their_mathtext_parses(monkeypatch, tmp_path):
    from matplotlib import _mathtext

    spec = {"kind": "control", "caption": r"commands of $\alpha$ and $\dot{q}$"}
    r = _result_for("hypersonic-direct-s1", spec)
    first = _png(r, spec, tmp_path / "a.png")
    parses = []
    real_parse = _mathtext.Parser.parse

    def counting_parse(self, s, *args, **kwargs):
        parses.append(s)
        return real_parse(self, s, *args, **kwargs)

    monkeypatch.setattr(_mathtext.Parser, "parse", counting_parse)
    again = _png(r, spec, tmp_path / "b.png")
    assert parses == []  # every label of the second figure was parsed for the first
    assert again == first
    # a figure drawn after others is the one matplotlib's own savefig draws, parsing afresh
    fp = plots.plot(r, "control", title=spec["caption"])
    with plots.figure_style():
        fp.figure.savefig(
            tmp_path / "c.png",
            dpi=plots.DPI,
            format="png",
            metadata=plots._metadata("png", spec["caption"]),
            pil_kwargs={"compress_level": plots.PNG_COMPRESS},
        )
    assert parses  # savefig's renderer parsed its own
    assert (tmp_path / "c.png").read_bytes() == first
