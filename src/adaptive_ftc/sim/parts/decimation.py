"""Decimation part: the anti-aliasing filter of a digital controller whose sensors are faster
than it (issue 25, session 14). The design's model asks for it
(:attr:`ConstraintAware.readings <adaptive_ftc.controllers.constraints.ConstraintAware.readings>`
= ``N`` >= 2): at its sample ``t_k`` the controller reads the mean of the ``N`` sensor readings
of the last period, at ``t_k - (N-1) T/N, ..., t_k`` (a boxcar, integrate-and-dump prefilter:
Franklin, Powell & Workman, *Digital Control of Dynamic Systems*, 3rd ed., 1998, §6.3.2 on
prefilters against aliasing; Åström & Wittenmark, *Computer-Controlled Systems*, 3rd ed.,
1997, §7.4). The loop breaks at every reading instant (the sample table of ``D.i`` flags
them 2, the controller's samples 1); ``jump`` adds the true state there to a running sum
(``nx`` states and a count, not integrated), the sample reads ``(sum + x) / (count + 1)``
plus the mean of the readings' bias and noise (``compose._measurements``) and empties the
sum. So the averaging of the state (its delay, ``(N-1)/(2N)`` of a period) is simulated, not
only the noise's ``1/sqrt(N)``. Nothing for any other loop."""

from __future__ import annotations

from adaptive_ftc.sim.parts.base import Build, Part

__all__ = ["Decimation", "MEASURED", "READING", "SAMPLE"]

#: the sample table's flag of an interval that starts at a controller sample
SAMPLE = 1
#: ... at a sensor reading between two samples (a decimating loop only)
READING = 2
#: the generated function through which the controller reads the filtered state,
#: ``measured(x, Y, ph, i, D)`` (the C export reads its own mean there: export/c.py)
MEASURED = "measured"


class Decimation(Part):
    """The running sum of the sensor readings of the current sample period."""

    def build(self, b: Build) -> None:
        self.at = -1
        if b.readings > 1:
            names = [f"decimation sum of x{i + 1}" for i in range(b.nx)]
            self.at = b.states.claim("decimation", b.nx + 1, [*names, "decimation count"])

    def jump_uses_scratch(self, b: Build) -> bool:
        return False

    def jump(self, b: Build) -> dict[str, list[str]]:
        if self.at < 0:
            return {}
        at, nx = self.at, b.nx
        return {
            "jump_reading": [
                f"    if D.i[D.i[I_SAMP] + ph] == {READING}:  # a reading between samples: summed",
                f"        for i in range({nx}):",
                f"            Y[{at} + i] += Y[i]",
                f"        Y[{at + nx}] += 1.0",
            ],
            "jump_sample_end": [
                f"        for i in range({nx + 1}):  # the decimation filter's sum emptied",
                f"            Y[{at} + i] = 0.0",
            ],
        }

    def tables(self, b: Build) -> list[str]:
        if self.at < 0:
            return []
        at, nx = self.at, b.nx
        return [
            "\n".join(
                [
                    "@inl",
                    f"def {MEASURED}(x, Y, ph, i, D):",
                    '    """State i as the controller reads it: the mean of the sample period\'s',
                    '    sensor readings (decimation filter), with their bias and noise."""',
                    f"    return (Y[{at} + i] + x[i]) / (Y[{at + nx}] + 1.0) + meas(ph, i, D)",
                ]
            )
        ]
