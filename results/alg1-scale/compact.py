"""Compacts result files for committing: drops `history` and `policy_soft` (recomputing J needs
neither) and writes compact JSON, in place. Usage: python3 results/alg1-scale/compact.py FILE…"""
import json
import sys

for path in sys.argv[1:]:
    with open(path) as f:
        r = json.load(f)
    for key in ("history", "policy_soft"):
        r.pop(key, None)
    with open(path, "w") as f:
        json.dump(r, f, separators=(",", ":"))
