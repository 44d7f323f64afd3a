"""results.csv and results.md of the benchmark, and the check that the outputs exist and parse."""
import csv
import io
import math
import os

from atomic import write_text
from trajectories import TrajectoryError, read_poses

COLUMNS = ["log", "method", "completed", "ate_m", "local_trans_m", "local_rot_deg",
           "loop_trans_m", "loop_rot_deg", "wall_s", "per_scan_ms_median", "peak_rss_mb",
           "map_bytes"]
EXTRA_COLUMNS = ["per_scan_ms_mean", "map_memory_bytes", "scans", "matched_poses", "trajectory",
                 "note"]
COMPLETED_VALUES = ("yes", "no", "not_run")
FORMATS = {"ate_m": "{:.4f}", "local_trans_m": "{:.4f}", "local_rot_deg": "{:.3f}",
           "loop_trans_m": "{:.4f}", "loop_rot_deg": "{:.3f}", "wall_s": "{:.2f}",
           "per_scan_ms_median": "{:.3f}", "per_scan_ms_mean": "{:.3f}",
           "peak_rss_mb": "{:.1f}", "map_bytes": "{:d}",
           "map_memory_bytes": "{:d}", "scans": "{:d}", "matched_poses": "{:d}"}


def _cell(row, key):
    value = row.get(key)
    if value is None:
        return ""
    if key in FORMATS and not isinstance(value, str):
        return FORMATS[key].format(value)
    return str(value)


def write_csv(path, rows):
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(COLUMNS + EXTRA_COLUMNS)
    for row in rows:
        writer.writerow([_cell(row, k) for k in COLUMNS + EXTRA_COLUMNS])
    write_text(path, out.getvalue())


MD_COLUMNS = [("log", "log"), ("method", "method"), ("completed", "done"), ("ate_m", "ATE m"),
              ("local_trans_m", "local m"), ("local_rot_deg", "local deg"),
              ("loop_trans_m", "revisit m"), ("loop_rot_deg", "revisit deg"),
              ("wall_s", "wall s"), ("per_scan_ms_median", "ms/scan median"),
              ("per_scan_ms_mean", "ms/scan mean"),
              ("peak_rss_mb", "peak RSS MB"), ("map_bytes", "map on disk B"),
              ("map_memory_bytes", "map in memory B")]


def markdown_table(rows):
    lines = ["| " + " | ".join(title for _, title in MD_COLUMNS) + " |",
             "|" + "|".join("---" if k in ("log", "method", "completed") else "---:"
                            for k, _ in MD_COLUMNS) + "|"]
    for row in rows:
        lines.append("| " + " | ".join(_cell(row, k) or "–" for k, _ in MD_COLUMNS) + " |")
    return "\n".join(lines)


def write_markdown(path, header_lines, rows, methods_lines, notes, plots):
    parts = ["# ShapeSLAM benchmark results", "", *header_lines, "", markdown_table(rows), "",
             "## Methods", "", *methods_lines, ""]
    if notes:
        parts += ["## Notes", "", *[f"- {n}" for n in notes], ""]
    if plots:
        names = [os.path.basename(p) for p in plots]
        parts += ["## Plots", "", *[f"![{n}]({n})" for n in names], ""]
    write_text(path, "\n".join(parts))


# --- checking ---------------------------------------------------------------------------------

def _number(text, what, problems):
    if text == "":
        return None
    try:
        value = float(text)
    except ValueError:
        problems.append(f"{what}: '{text}' is not a number")
        return None
    if not math.isfinite(value):
        problems.append(f"{what}: {text} is not finite")
    return value


def _check_row(row, out_dir, has_reference, require_completed, problems):
    where = f"results.csv {row['log']}/{row['method']}"
    if row["completed"] not in COMPLETED_VALUES:
        problems.append(f"{where}: completed is '{row['completed']}'")
    for key in COLUMNS[3:] + EXTRA_COLUMNS[:4]:
        _number(row[key], f"{where} {key}", problems)
    if row["completed"] == "no" and require_completed:
        problems.append(f"{where}: did not complete ({row['note']})")
    if row["completed"] != "yes":
        return
    if has_reference.get(row["log"]) and _number(row["ate_m"], where, []) is None:
        problems.append(f"{where}: completed with a reference but has no ATE ({row['note']})")
    traj = os.path.join(out_dir, row["trajectory"]) if row["trajectory"] else ""
    try:
        if not traj or not read_poses(traj):
            problems.append(f"{where}: no trajectory file or an empty one")
    except (OSError, TrajectoryError) as e:
        problems.append(f"{where}: trajectory does not parse: {e}")


def check_outputs(out_dir, expected_pairs, has_reference, pngs, require_completed):
    """Problems found (empty = fine): every file exists and parses, one CSV row per expected
    (log, method), an ATE for each completed run on a log with a reference, and, with
    require_completed, no run that was attempted and did not complete."""
    problems = []
    csv_path = os.path.join(out_dir, "results.csv")
    try:
        with open(csv_path, newline="") as f:
            reader = csv.DictReader(f)
            header = reader.fieldnames or []
            rows = list(reader)
    except OSError as e:
        return [f"results.csv: {e}"]
    if header[:len(COLUMNS)] != COLUMNS:
        problems.append(f"results.csv: columns {header[:len(COLUMNS)]}, expected {COLUMNS}")
        return problems
    found = {(r["log"], r["method"]) for r in rows}
    problems += [f"results.csv: no row for {log}/{method}" for log, method in expected_pairs
                 if (log, method) not in found]
    for row in rows:
        _check_row(row, out_dir, has_reference, require_completed, problems)
    md_path = os.path.join(out_dir, "results.md")
    try:
        with open(md_path) as f:
            md = f.read()
        if not all(f"| {log} | {method} |" in md for log, method in expected_pairs):
            problems.append("results.md: the table misses a run")
    except OSError as e:
        problems.append(f"results.md: {e}")
    for png in pngs:
        try:
            with open(png, "rb") as f:
                if f.read(8) != b"\x89PNG\r\n\x1a\n":
                    problems.append(f"{png}: not a PNG file")
        except OSError as e:
            problems.append(f"{png}: {e}")
    return problems
