"""PNG plots of the benchmark: trajectories per log, and an error/time comparison chart.

Needs matplotlib (Debian package python3-matplotlib). Files are written atomically."""
import math
import os
import statistics

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from atomic import temp_path_for  # noqa: E402
from trajectories import align_onto  # noqa: E402

COLORS = ["tab:blue", "tab:orange", "tab:green", "tab:red", "tab:purple", "tab:brown", "tab:pink",
          "tab:olive", "tab:cyan"]


def _save(fig, path):
    tmp = temp_path_for(path)
    try:
        fig.savefig(tmp, format="png", dpi=110, bbox_inches="tight")
        os.chmod(tmp, 0o644)
        os.replace(tmp, path)
    finally:
        plt.close(fig)
        if os.path.exists(tmp):
            os.unlink(tmp)


def trajectory_plot(path, log_name, reference, runs):
    """runs: [(method, poses or None, note)]. Each trajectory is moved onto the reference by the
    best rigid alignment, as eval does; without a reference, onto the first run's trajectory."""
    fig, ax = plt.subplots(figsize=(8, 7))
    anchor = reference or next((p for _, p, _ in runs if p), None)
    if reference:
        ax.plot([p[1] for p in reference], [p[2] for p in reference], color="black", lw=2.2,
                alpha=0.35, label="reference")
    for i, (method, poses, note) in enumerate(runs):
        color = COLORS[i % len(COLORS)]
        if not poses:
            ax.plot([], [], color=color, label=f"{method}: {note or 'no trajectory'}")
            continue
        moved, ate = align_onto(poses, anchor) if anchor else (None, None)
        moved = moved or poses
        label = f"{method}" + (f" (ATE {ate:.2f} m)" if reference and ate is not None else "")
        ax.plot([p[1] for p in moved], [p[2] for p in moved], color=color, lw=0.9, label=label)
    title = f"{log_name}: trajectories after best rigid alignment onto the reference"
    if not reference:
        title = f"{log_name}: no reference; trajectories aligned onto {runs[0][0]}"
    ax.set_title(title, fontsize=10)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(True, lw=0.3)
    ax.legend(fontsize=8, loc="best")
    _save(fig, path)


PANELS = [("ate_m", "ATE (m)"), ("local_trans_m", "local relation error (m)"),
          ("loop_trans_m", "revisit relation error (m)"), ("wall_s", "wall time (s)")]


def _values(rows, log, method, key):
    """The finite, positive values of key over the runs of a log and method (its copies)."""
    return [v for r in rows if r["log"] == log and r["method"] == method
            and (v := r.get(key)) is not None and math.isfinite(v) and v > 0]


def _bar_panel(ax, rows, logs, methods, key, title):
    """A bar per log and method at the median over its runs, whiskers at min and max when
    there are several (perturbed copies)."""
    width = 0.8 / max(1, len(methods))
    values = [v for r in rows if (v := r.get(key)) is not None and v > 0]
    floor = min(values) / 3 if values else 0.01
    labelled = set()
    for m, method in enumerate(methods):
        for l, log in enumerate(logs):
            runs = _values(rows, log, method, key)
            x = l - 0.4 + width * (m + 0.5)
            if not runs:
                ax.text(x, floor * 1.1, "x", ha="center", va="bottom", fontsize=7, color="gray")
                continue
            value = statistics.median(runs)
            ax.bar(x, value, width, color=COLORS[m % len(COLORS)],
                   label=None if method in labelled else method)
            if len(runs) > 1:
                ax.errorbar(x, value, yerr=[[value - min(runs)], [max(runs) - value]], fmt="none",
                            ecolor="black", elinewidth=0.7, capsize=1.5)
            ax.text(x, max(runs) * 1.08, f"{value:.3g}", ha="center", va="bottom", fontsize=6,
                    rotation=90)
            labelled.add(method)
    ax.set_yscale("log")
    ax.set_ylim(bottom=floor, top=max(values) * 6 if values else 1.0)
    ax.set_xticks(range(len(logs)))
    ax.set_xticklabels(logs, fontsize=8)
    ax.set_title(title, fontsize=10)
    ax.grid(True, axis="y", which="both", lw=0.3)


def comparison_plot(path, rows, logs, methods):
    """rows: dicts with log, method and the PANELS keys (None when not available)."""
    fig, axes = plt.subplots(2, 2, figsize=(12, 8))
    for ax, (key, title) in zip(axes.flat, PANELS):
        _bar_panel(ax, rows, logs, methods, key, title)
    handles, labels = [], []
    for ax in axes.flat:
        for h, lab in zip(*ax.get_legend_handles_labels()):
            if lab not in labels:
                handles.append(h)
                labels.append(lab)
    fig.legend(handles, labels, loc="upper center", ncol=len(labels), fontsize=9)
    fig.text(0.5, 0.005, "log scale; x = not completed, not run or no reference; with several "
             "runs (perturbed copies): bar at the median, whiskers at min and max", ha="center",
             fontsize=8, color="gray")
    fig.tight_layout(rect=(0, 0.02, 1, 0.94))
    _save(fig, path)
