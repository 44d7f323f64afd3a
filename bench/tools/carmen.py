"""Just enough of the CARMEN text format for the benchmark: laser scan timestamps, and the first
N scans of a log (with its reference poses and relations) for the --quick run.

The reader that matters is shape-slam's own (src/io/carmen_reader.cpp); this one is a fallback
and its results are checked against the scan count `shape-slam convert` reports."""
import gzip

from atomic import write_text


def _open_text(path):
    with open(path, "rb") as f:
        gz = f.read(2) == b"\x1f\x8b"
    return gzip.open(path, "rt", errors="replace") if gz else open(path, errors="replace")


def _scan_stamp(fields):
    """The `timestamp` field of a FLASER or ROBOTLASER1 record, or None if malformed."""
    try:
        if fields[0] == "FLASER":
            n = int(fields[1])
            return float(fields[2 + n + 6])
        n = int(fields[8])
        n_rem = int(fields[9 + n])
        return float(fields[9 + n + 1 + n_rem + 11])
    except (ValueError, IndexError):
        return None


def scan_stamps(path):
    """Timestamps of the laser scans in log order (ROBOTLASER1 if the log has any, else FLASER),
    as shape-slam reads them; malformed records are skipped."""
    stamps = {"FLASER": [], "ROBOTLASER1": []}
    with _open_text(path) as f:
        for line in f:
            fields = line.split()
            if fields and fields[0] in stamps:
                t = _scan_stamp(fields)
                if t is not None:
                    stamps[fields[0]].append(t)
    return stamps["ROBOTLASER1"] or stamps["FLASER"]


def write_head(path, out_log, max_scans):
    """Writes the records of path up to its max_scans-th FLASER record (and every PARAM record)
    to out_log. Returns the timestamps of the scans kept."""
    kept, stamps = [], []
    with _open_text(path) as f:
        for line in f:
            fields = line.split()
            if not fields:
                continue
            if fields[0] == "FLASER":
                if len(stamps) >= max_scans:
                    continue
                t = _scan_stamp(fields)
                if t is None:
                    continue
                stamps.append(t)
            elif fields[0] != "PARAM" and len(stamps) >= max_scans:
                continue
            kept.append(line if line.endswith("\n") else line + "\n")
    write_text(out_log, "".join(kept))
    return stamps


def write_subset_by_stamps(path, out_path, stamps, columns):
    """Copies the lines of a reference file (gt: columns=1, relations: columns=2) whose first
    `columns` timestamps are all among stamps."""
    keep = {round(t, 6) for t in stamps}
    lines = []
    with open(path) as f:
        for line in f:
            fields = line.split()
            if len(fields) < columns or fields[0].startswith("#"):
                continue
            if all(round(float(v), 6) in keep for v in fields[:columns]):
                lines.append(line if line.endswith("\n") else line + "\n")
    write_text(out_path, "".join(lines))
    return len(lines)
