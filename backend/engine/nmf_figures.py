"""The paper's NMF figures, drawn from the filter itself (used by `nutty figures`)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from backend.engine import nmf_examples as ex
from backend.engine.nmf import PRESETS, MotionFilter, omega, stabilise
from backend.engine.trajectory import derivatives

COLOURS = {"W": "#1f77b4", "A": "#ff7f0e", "B": "#2ca02c", "C": "#d62728", "D": "#9467bd", "E": "#8c564b"}


def _plt():
    # matplotlib loads only for `nutty figures`: a second of import the server never needs
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # after use("Agg"): pyplot picks its backend on import

    plt.rcParams.update(
        {
            "figure.dpi": 110,
            "axes.grid": True,
            "grid.alpha": 0.3,
            "font.size": 9,
            "axes.spines.top": False,
            "axes.spines.right": False,
        }
    )
    return plt


def _filter(name: str, x: np.ndarray, order: int = 3, limiter: str = "tanh") -> np.ndarray:
    return (
        MotionFilter.from_preset(name, 1, ex.RATE, order=order, limiter=limiter)
        .run(x[:, None])
        .position[:, 0]
    )


def _label(name: str) -> str:
    return f"{name} {PRESETS[name].meaning}"


# W and B nearly coincide on large steps (B's H is ~identity above v ~ 7): W is drawn wide and pale
# underneath so that it stays visible.
def _style(name: str) -> dict:
    return {"lw": 3.5, "alpha": 0.45, "zorder": 1} if name == "W" else {"lw": 1.5, "zorder": 2}


DERIV_LABELS = ("velocity [units/s]", "acceleration [units/s²]", "jerk [units/s³]")


def fig_inputs(plt, out: Path) -> Path:
    fig, axes = plt.subplots(1, 3, figsize=(12, 3), sharey=True)
    t = ex.times()
    for ax, (name, fn) in zip(axes, ex.EXAMPLES.items()):
        ax.step(t, fn(), where="post", color="k")
        ax.set_title(f"{name}")
        ax.set_xlabel("t [s]")
    axes[0].set_ylabel("set-point [units]")
    fig.suptitle("The paper's example inputs (60 Hz, 10 s)")
    return _save(fig, out / "nmf_inputs.png")


def fig_h(plt, out: Path) -> Path:
    fig, axes = plt.subplots(1, 2, figsize=(11, 3.6))
    for ax, names, vmax in ((axes[0], "WAB", 20.0), (axes[1], "WCDE", 90.0)):
        v = np.linspace(0, vmax, 400)
        for name in names:
            p = PRESETS[name]
            h = v if p.bypass else stabilise(v, p.sigma, p.rho)
            ax.plot(
                v,
                h,
                color=COLOURS[name],
                label=_label(name) + ("" if p.bypass else f" (σ={p.sigma}, ρ={p.rho})"),
            )
        ax.set_xlabel("induced velocity v [units/s]")
        ax.set_ylabel("target velocity H(v) [units/s]")
        ax.set_title(f"stabilisation function H over [0, {vmax:g}]")
        ax.legend(fontsize=7)
    return _save(fig, out / "nmf_h.png")


def fig_omega(plt, out: Path) -> Path:
    fig, ax = plt.subplots(figsize=(7, 3.6))
    x = np.linspace(-10, 20, 600)
    for beta, style in ((5, "-"), (20, "--"), (100, ":")):
        ax.plot(x, omega(1.0, x, -10.0, 20.0, beta), style, color="#1f77b4", label=f"β={beta}, v > 0")
        ax.plot(x, -omega(-1.0, x, -10.0, 20.0, beta), style, color="#d62728", label=f"β={beta}, v < 0")
    ax.set_xlabel("position x [units] (Pmin = -10, Pmax = 20: the spec's example range)")
    ax.set_ylabel("Ω(v, x) / v  (fraction of v kept)")
    ax.set_title("position saturation Ω: speed toward a limit fades to zero")
    ax.legend(fontsize=7, ncol=2)
    return _save(fig, out / "nmf_omega.png")


def _presets_on(plt, out: Path, name: str, x: np.ndarray, fname: str, limiter: str = "tanh") -> Path:
    t = ex.times()
    fig, axes = plt.subplots(4, 1, figsize=(10, 9), sharex=True, gridspec_kw={"height_ratios": [3, 1, 1, 1]})
    axes[0].step(t, x, where="post", color="k", ls="--", lw=1, label="set-point")
    for p in PRESETS:
        y = _filter(p, x, limiter=limiter)
        vel, acc, jerk = derivatives(np.r_[y[0], y], ex.RATE)
        axes[0].plot(t, y, color=COLOURS[p], label=_label(p), **_style(p))
        for ax, d in zip(axes[1:], (vel, acc, jerk)):
            ax.plot(t, d[1:, 0], color=COLOURS[p], lw=0.8)
    axes[0].set_title(
        f"all presets on {name} — order 3, {limiter} limiter (derivatives: finite differences of the output)"
    )
    axes[0].set_ylabel("position [units]")
    lo, hi = axes[0].get_ylim()
    axes[0].set_ylim(lo - 0.35 * (hi - lo), hi)  # room for the legend below the curves
    axes[0].legend(fontsize=7, ncol=4, loc="lower center")
    for ax, lab in zip(axes[1:], DERIV_LABELS):
        ax.set_ylabel(lab)
    axes[-1].set_xlabel("t [s]")
    return _save(fig, out / fname)


def fig_tanh_vs_hard(plt, out: Path) -> Path:
    x = ex.phi_l()
    t = ex.times()
    fig, axes = plt.subplots(2, 3, figsize=(13, 6), sharex=True, sharey=True)
    for row, limiter in enumerate(("tanh", "hard")):
        for col, names in enumerate(("WAB", "CDE", "WC")):
            ax = axes[row, col]
            ax.step(t, x, where="post", color="k", ls="--", lw=1)
            for p in names:
                ax.plot(t, _filter(p, x, limiter=limiter), color=COLOURS[p], label=_label(p), **_style(p))
            ax.set_title(f"Φ_L, {limiter} limiter")
            ax.legend(fontsize=7, loc="lower left")
    for ax in axes[-1]:
        ax.set_xlabel("t [s]")
    for ax in axes[:, 0]:
        ax.set_ylabel("position [units]")
    fig.suptitle(
        "Each preset on Φ_L with the tanh and the hard limiter (hard: larger overshoot and oscillation)"
    )
    return _save(fig, out / "nmf_presets_phi_l.png")


def fig_orders(plt, out: Path) -> Path:
    x = ex.phi_l()
    t = ex.times()
    fig, axes = plt.subplots(4, 3, figsize=(13, 8), sharex=True, gridspec_kw={"height_ratios": [3, 1, 1, 1]})
    for col, order in enumerate((1, 2, 3)):
        axes[0, col].step(t, x, where="post", color="k", ls="--", lw=1)
        for p in "WAD":
            y = _filter(p, x, order=order)
            vel, acc, jerk = derivatives(np.r_[y[0], y], ex.RATE)
            axes[0, col].plot(t, y, color=COLOURS[p], label=_label(p), **_style(p))
            for r, d in enumerate((vel, acc, jerk), start=1):
                axes[r, col].plot(t, d[1:, 0], color=COLOURS[p], lw=0.8)
        axes[0, col].set_title(f"order {order} ({('velocity', 'acceleration', 'jerk')[order - 1]} limited)")
        axes[0, col].legend(fontsize=7, loc="center right")
        axes[-1, col].set_xlabel("t [s]")
    for r, lab in enumerate(("position [units]", *DERIV_LABELS)):
        axes[r, 0].set_ylabel(lab)
    fig.suptitle("Orders 1-3 side by side on Φ_L: lower order, higher sustained velocity for the same limits")
    return _save(fig, out / "nmf_orders.png")


def fig_overview(plt, out: Path) -> Path:
    """The four-panel summary shown in the README."""
    t = ex.times()
    fig, axes = plt.subplots(2, 2, figsize=(12, 7))
    for ax, (name, fn) in zip((axes[0, 0], axes[0, 1], axes[1, 0]), ex.EXAMPLES.items()):
        x = fn()
        ax.step(t, x, where="post", color="k", ls="--", lw=1, label="set-point")
        for p in PRESETS:
            ax.plot(t, _filter(p, x), color=COLOURS[p], label=_label(p), **_style(p))
        ax.set_title(f"{name} — order 3, tanh limiter")
        ax.set_xlabel("t [s]")
        ax.set_ylabel("position [units]")
    axes[0, 0].legend(fontsize=7)
    ax = axes[1, 1]
    x = ex.phi_l()
    ax.step(t, x, where="post", color="k", ls="--", lw=1)
    for p, limiter, style in (("W", "tanh", "-"), ("A", "tanh", "-"), ("W", "hard", ":"), ("A", "hard", ":")):
        ax.plot(t, _filter(p, x, limiter=limiter), style, color=COLOURS[p], label=f"{p} position ({limiter})")
    a = MotionFilter.from_preset("A", 1, ex.RATE).run(x[:, None])
    ax.plot(t, a.velocity[:, 0], color="#9467bd", label="A velocity (tanh)")
    ax.set_title(
        f"Φ_L: tanh vs hard limiter; A peaks at {np.abs(a.velocity).max():.1f} of its velocity limit 20"
    )
    ax.set_xlabel("t [s]")
    ax.set_ylabel("position [units], velocity [units/s]")
    ax.legend(fontsize=7)
    fig.tight_layout()
    return _save(fig, out / "nmf_overview.png")


def _save(fig, path: Path) -> Path:
    fig.tight_layout()
    fig.savefig(path)
    import matplotlib.pyplot as plt  # loaded by _plt() already; only the name is bound here

    plt.close(fig)
    return path


def draw_all(out: Path) -> list[Path]:
    plt = _plt()
    return [
        fig_inputs(plt, out),
        fig_h(plt, out),
        fig_omega(plt, out),
        fig_tanh_vs_hard(plt, out),
        fig_orders(plt, out),
        _presets_on(plt, out, "Φ_R", ex.phi_r(), "nmf_presets_phi_r.png"),
        _presets_on(plt, out, "Φ_C", ex.phi_c(), "nmf_presets_phi_c.png"),
        fig_overview(plt, out),
    ]
