"""Compares sweep CSVs cell by cell, apart from the wall-time column `seconds` (the one column two runs of the same
points may differ in): exits 1 naming the first difference. Used by the cluster tests.

  compare_sweeps.py EXPECTED.csv ACTUAL.csv
      the same header, and the same rows as a set (ACTUAL's rows may come in another order: a merge groups them
      by shard), each point once
  compare_sweeps.py --shard K N EXPECTED.csv SHARD.csv
      SHARD holds exactly rows K-1, K-1+N, K-1+2N, ... of EXPECTED, in that order (rtusim sweep --shard K/N)
  compare_sweeps.py --same-order EXPECTED.csv ACTUAL.csv...
      each ACTUAL has EXPECTED's lines in EXPECTED's order, byte for byte apart from the seconds column (tables
      collected from one manifest by different engines)"""
import csv
import sys

IGNORED = {"seconds"}


def rows(path):
    with open(path, newline="", encoding="utf-8-sig") as f:
        r = list(csv.reader(f))
    if not r:
        sys.exit(f"compare_sweeps: {path} is empty")
    header = r[0]
    keep = [i for i, name in enumerate(header) if name not in IGNORED]
    if len(keep) == len(header):
        sys.exit(f"compare_sweeps: {path} has no 'seconds' column: not a sweep CSV")
    return [header[i] for i in keep], [tuple(row[i] for i in keep) for row in r[1:]]


def same_order(expected, actuals):
    eh, erows = rows(expected)
    with open(expected, "rb") as f:
        lines = f.read().splitlines()
    for path in actuals:
        ah, arows = rows(path)
        with open(path, "rb") as f:
            alines = f.read().splitlines()
        if ah != eh or arows != erows or len(alines) != len(lines):
            first = next((i for i, (a, b) in enumerate(zip(erows, arows)) if a != b), min(len(erows), len(arows)))
            sys.exit(f"compare_sweeps: {path} differs from {expected} at row {first + 1} (apart from seconds)")
        print(f"compare_sweeps: {path}: {len(arows)} rows, {expected}'s in its order, apart from seconds")


def main(argv):
    if argv[:1] == ["--same-order"] and len(argv) >= 3:
        return same_order(argv[1], argv[2:])
    shard = None
    if argv[:1] == ["--shard"]:
        shard = (int(argv[1]), int(argv[2]))
        argv = argv[3:]
    if len(argv) != 2:
        sys.exit(__doc__)
    (eh, expected), (ah, actual) = rows(argv[0]), rows(argv[1])
    if eh != ah:
        sys.exit(f"compare_sweeps: headers differ:\n  {eh}\n  {ah}")
    if shard:
        k, n = shard
        want = expected[k - 1::n]
        if actual != want:
            sys.exit(f"compare_sweeps: {argv[1]} is not shard {k}/{n} of {argv[0]}:\n  {actual}\nwanted\n  {want}")
        print(f"compare_sweeps: {argv[1]}: shard {k}/{n}, {len(actual)} rows, equal apart from seconds")
        return
    if len(set(actual)) != len(actual):
        sys.exit(f"compare_sweeps: {argv[1]} holds a row twice")
    missing, extra = set(expected) - set(actual), set(actual) - set(expected)
    if missing or extra:
        sys.exit(f"compare_sweeps: rows differ apart from seconds:\n  only in {argv[0]}: {sorted(missing)}\n"
                 f"  only in {argv[1]}: {sorted(extra)}")
    print(f"compare_sweeps: {argv[1]}: {len(actual)} rows, equal to {argv[0]} apart from seconds and row order")


main(sys.argv[1:])
