"""Figures of djkr results with matplotlib (optional: ``pip install matplotlib``).

``djkr.plot.run(r)`` draws a ``djkr.Run`` as ``djkr plot`` draws ``run.png``'s time panels:
each gap-free piece of the time series (``Run.pieces()``) as its own line, never a line across
a span envelope following skipped (shaded, with the periods skipped in the legend), the stage
starts dashed, the detachment as a ring, and the pull-off at its force and time only when the
run detached with a tensile force. Each axis in the SI prefix its values suit (mN, mm, µm); the
legends beside the panels, off the data.

>>> import djkr, djkr.plot
>>> fig = djkr.plot.run(djkr.run("scenarios/paper-protocol-300hz.toml"))
>>> fig.savefig("run.png")
"""

import math

__all__ = ["run", "prefixed"]

# (array name, quantity, SI unit) of the panels, as run.png's.
PANELS = {
    "F": ("contact force F, compressive +", "N"),
    "a": ("contact radius a", "m"),
    "delta": ("indentation δ", "m"),
    "x_s": ("sphere position x_s, down +", "m"),
    "G": ("energy release rate G", "J/m²"),
    "w": ("work of adhesion w", "J/m²"),
}
_PREFIXES = [(1e-9, "n"), (1e-6, "µ"), (1e-3, "m"), (1.0, ""), (1e3, "k"), (1e6, "M")]


def prefixed(values, unit):
    """(scale, unit) for showing ``values`` (SI, in ``unit``): the largest SI prefix under which
    the largest magnitude is at least 1, so that ``values * scale`` reads in ``prefix + unit``
    (``(1e3, "mN")`` for forces of tenths of a newton). ``(1, unit)`` without finite values."""
    top = max((abs(v) for v in values if math.isfinite(v)), default=0.0)
    if top == 0.0:
        return 1.0, unit
    factor, prefix = _PREFIXES[0]
    for f, p in _PREFIXES:
        if top >= f:
            factor, prefix = f, p
    return 1.0 / factor, prefix + unit


def _pull_off(r):
    """(time, force, label) of the pull-off to mark, or None: only for a run that detached with
    a tensile force (``summary.json``'s ``detached``, ``pull_off.tensile``)."""
    s = r.summary
    p = s.get("pull_off", {})
    if not s.get("detached") or not p.get("tensile") or "force" not in p or "time" not in p:
        return None
    t = p["time"]
    # Under vibration the pull-off force is a cycle mean, reached at the end of its period.
    ends = r.cycles.get("t_end", [])
    mean = any(abs(e - t) <= 1e-9 * max(abs(t), 1e-300) for e in ends)
    return t, p["force"], "pull-off: most tensile ⟨F⟩" if mean else "pull-off: most tensile F"


def run(r, quantities=("F", "a", "delta"), axes=None, title=None):
    """Draw the time panels of a run, as ``djkr plot`` does, and return the figure.

    Parameters
    ----------
    r : djkr.Run
        The run (``djkr.run(...)``).
    quantities : sequence of str
        The arrays to draw, one panel each, from ``F``, ``a``, ``delta``, ``x_s``, ``G``, ``w``
        (default ``F``, ``a``, ``delta``).
    axes : sequence of matplotlib Axes, optional
        Where to draw (one per quantity); default a new figure with the panels stacked.
    title : str, optional
        The figure's title (default the run's scenario).
    """
    import matplotlib.pyplot as plt

    if axes is None:
        fig, axes = plt.subplots(len(quantities), 1, figsize=(9, 2.2 * len(quantities) + 0.6),
                                 sharex=True, squeeze=False)
        axes = axes[:, 0]
    else:
        fig = axes[0].figure
    pieces = r.pieces()
    t_scale, t_unit = prefixed([r.t[0], r.t[-1]] if len(r) else [], "s")
    gaps = r.gaps
    skipped = int(sum(gaps.get("periods", []))) if len(gaps.get("t_start", [])) else 0
    stage_starts = [e["time"] for e in r.events if e["kind"] == "stage-start" and e["time"] > 0]
    detachments = [e for e in r.events if e["kind"] == "pull-off"]
    pull_off = _pull_off(r)
    for ax, name in zip(axes, quantities):
        quantity, si = PANELS[name]
        values = getattr(r, name)
        scale, unit = prefixed(values, si)
        for k, p in enumerate(pieces):
            ax.plot(p["t"] * t_scale, p[name] * scale, color="C0", lw=0.6,
                    label=name if k == 0 else None)
        for k, (a, b) in enumerate(zip(gaps.get("t_start", []), gaps.get("t_end", []))):
            ax.axvspan(a * t_scale, b * t_scale, color="0.85", zorder=0,
                       label=f"envelope: {skipped} periods skipped" if k == 0 else None)
        for k, t in enumerate(stage_starts):
            ax.axvline(t * t_scale, ls="--", lw=0.8, color="0.5",
                       label="stage start" if k == 0 else None)
        for k, e in enumerate(detachments):
            ax.plot(e["time"] * t_scale, e["state"][name] * scale, "o", mfc="none", ms=9,
                    color="C3", label="detachment" if k == 0 else None)
        if name == "F" and pull_off is not None:
            t, force, label = pull_off
            ax.plot(t * t_scale, force * scale, "s", color="C1", label=label)
        ax.set_ylabel(f"{quantity} ({unit})")
        # Beside the panel, never on the data (as run.png's legends).
        ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0, fontsize="small")
    axes[-1].set_xlabel(f"t ({t_unit})")
    fig.suptitle(title if title is not None else r.summary.get("scenario", ""))
    fig.tight_layout()
    return fig
