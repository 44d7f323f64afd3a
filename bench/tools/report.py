"""results.csv and results.md of the benchmark, and the check that the outputs exist and parse."""
import csv
import io
import math
import os
import statistics

from atomic import write_text
from trajectories import TrajectoryError, read_poses

COLUMNS = ["log", "method", "completed", "ate_m", "local_trans_m", "local_rot_deg",
           "loop_trans_m", "loop_rot_deg", "wall_s", "per_scan_ms_median", "peak_rss_mb",
           "map_bytes"]
EXTRA_COLUMNS = ["per_scan_ms_mean", "map_memory_bytes", "scans", "matched_poses",
                 "gross_local_errors", "steps", "copy", "trajectory", "note"]
NUMERIC_EXTRA = EXTRA_COLUMNS[:7]
COMPLETED_VALUES = ("yes", "no", "not_run")
FORMATS = {"ate_m": "{:.4f}", "local_trans_m": "{:.4f}", "local_rot_deg": "{:.3f}",
           "loop_trans_m": "{:.4f}", "loop_rot_deg": "{:.3f}", "wall_s": "{:.2f}",
           "per_scan_ms_median": "{:.3f}", "per_scan_ms_mean": "{:.3f}",
           "peak_rss_mb": "{:.1f}", "map_bytes": "{:d}",
           "map_memory_bytes": "{:d}", "scans": "{:d}", "matched_poses": "{:d}",
           "gross_local_errors": "{:d}", "steps": "{:d}", "copy": "{:d}"}


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
              ("gross", "gross local errors"), ("wall_s", "wall s"),
              ("per_scan_ms_median", "ms/scan median"),
              ("per_scan_ms_mean", "ms/scan mean"),
              ("peak_rss_mb", "peak RSS MB"), ("map_bytes", "map on disk B"),
              ("map_memory_bytes", "map in memory B")]


def _md_cell(row, key):
    if key == "gross":  # gross local errors of steps
        errors, steps = row.get("gross_local_errors"), row.get("steps")
        return "" if errors is None else f"{errors} of {steps}"
    return _cell(row, key)


def markdown_table(rows, columns=None):
    if columns is None:
        copies = any(r.get("copy") is not None for r in rows)
        columns = MD_COLUMNS[:2] + [("copy", "copy")] * copies + MD_COLUMNS[2:]
    lines = ["| " + " | ".join(title for _, title in columns) + " |",
             "|" + "|".join("---" if k in ("log", "method", "completed") else "---:"
                            for k, _ in columns) + "|"]
    for row in rows:
        lines.append("| " + " | ".join(_md_cell(row, k) or "–" for k, _ in columns) + " |")
    return "\n".join(lines)


# --- spread over perturbed copies -------------------------------------------------------------

SPREAD_COLUMNS = [("log", "log"), ("method", "method"), ("completed", "runs done"),
                  ("ate_m", "ATE m"), ("local_trans_m", "local m"),
                  ("loop_trans_m", "revisit m"), ("loop_rot_deg", "revisit deg"),
                  ("gross_local_errors", "gross local errors"), ("wall_s", "wall s"),
                  ("per_scan_ms_median", "ms/scan median"), ("peak_rss_mb", "peak RSS MB")]
SPREAD_FORMATS = {"ate_m": "{:.3f}", "local_trans_m": "{:.3f}", "loop_trans_m": "{:.3f}",
                  "loop_rot_deg": "{:.2f}", "gross_local_errors": "{:g}", "wall_s": "{:.1f}",
                  "per_scan_ms_median": "{:.2f}", "peak_rss_mb": "{:.0f}"}


def _spread(values, fmt):
    """'median [min-max]' of the values (one value: itself), '' when there is none."""
    values = [v for v in values if v is not None]
    if not values:
        return ""
    if len(values) == 1:
        return fmt.format(values[0])
    return (fmt.format(statistics.median(values)) + " [" + fmt.format(min(values)) + "-"
            + fmt.format(max(values)) + "]")


def spread_rows(rows):
    """One row of cells per log and method (in the order of rows): median [min-max] over its
    completed runs; runs done 'completed of runs'; gross local errors with the steps."""
    groups = {}
    for row in rows:
        groups.setdefault((row["log"], row["method"]), []).append(row)
    result = []
    for (log, method), runs in groups.items():
        done = [r for r in runs if r["completed"] == "yes"]
        not_run = all(r["completed"] == "not_run" for r in runs)
        cells = {"log": log, "method": method,
                 "completed": "not_run" if not_run else f"{len(done)} of {len(runs)}"}
        for key, fmt in SPREAD_FORMATS.items():
            cells[key] = _spread([r.get(key) for r in done], fmt)
        steps = sorted({r["steps"] for r in done if r.get("steps") is not None})
        if cells["gross_local_errors"] and steps:
            cells["gross_local_errors"] += " of " + "/".join(str(s) for s in steps)
        result.append(cells)
    return result


def spread_table(rows):
    return markdown_table(spread_rows(rows), SPREAD_COLUMNS)


def write_markdown(path, header_lines, rows, methods_lines, notes, plots, spread=False):
    """results.md; spread: first the median [min-max] table over the copies, then every run."""
    tables = [markdown_table(rows)] if not spread else [
        SPREAD_TITLE, "", spread_table(rows), "",
        "## Every run", "", markdown_table(rows)]
    parts = ["# ShapeSLAM benchmark results", "", *header_lines, "", *tables, "",
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
    for key in COLUMNS[3:] + NUMERIC_EXTRA:
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
        problems += _check_markdown_spread(md, rows, expected_pairs)
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


SPREAD_TITLE = "## Median [min-max] over the perturbed copies"


def _check_markdown_spread(md, rows, expected_pairs):
    """With copies, the median table of results.md must hold every log and method."""
    if not any(r.get("copy", "") != "" for r in rows):
        return []
    if SPREAD_TITLE not in md:
        return ["results.md: runs with copies but no median [min-max] table"]
    table = md.split(SPREAD_TITLE, 1)[1].split("\n## ", 1)[0]
    if not all(f"| {log} | {method} |" in table for log, method in expected_pairs):
        return ["results.md: the median [min-max] table misses a log or method"]
    return []


def check_copies(out_dir, expected):
    """Problems with the run count: expected {(log, method): runs}; results.csv must hold that
    many rows of each, with distinct copies when more than one."""
    try:
        with open(os.path.join(out_dir, "results.csv"), newline="") as f:
            rows = list(csv.DictReader(f))
    except OSError as e:
        return [f"results.csv: {e}"]
    problems = []
    for (log, method), count in expected.items():
        copies = [r.get("copy", "") for r in rows if r["log"] == log and r["method"] == method]
        if len(copies) != count or (count > 1 and len(set(copies)) != count):
            problems.append(f"results.csv: {log}/{method} has {len(copies)} run(s) (copies "
                            f"{sorted(copies)}), expected {count}")
    return problems
