#!/usr/bin/env python3
"""What the training report adds to a replay (docs/report.md): wall-clock seconds of
`organsim replay` with and without `--report`, in session time (--fast, median of
three) and in real time (once each: the real-time run adds the machine-floor probe,
as long as the session), and of `organsim report` rebuilding the page. Prints JSON.

  python3 tools/benchmarks/report_cost.py --build build MODEL SESSION
"""
import argparse
import json
import os
import statistics
import subprocess
import tempfile
import time


def seconds(command):
    start = time.perf_counter()
    subprocess.run(command, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return time.perf_counter() - start


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--build", default="build")
    parser.add_argument("model")
    parser.add_argument("session")
    args = parser.parse_args()
    replay = [os.path.join(args.build, "tools", "organsim"), "replay", args.model, args.session, "--quiet"]
    with tempfile.TemporaryDirectory() as work:
        fast_plain, fast_report = [], []
        for k in range(3):
            fast_plain.append(seconds(replay + ["--fast"]))
            fast_report.append(seconds(replay + ["--fast", "--report", os.path.join(work, f"fast{k}")]))
        realtime_plain = seconds(replay)
        realtime_report = seconds(replay + ["--report", os.path.join(work, "realtime")])
        rebuild = statistics.median(
            seconds([os.path.join(args.build, "tools", "organsim"), "report", os.path.join(work, "fast0")])
            for _ in range(3))
    print(json.dumps({"fast_plain_s": statistics.median(fast_plain), "fast_report_s": statistics.median(fast_report),
                      "realtime_plain_s": realtime_plain, "realtime_report_s": realtime_report,
                      "rebuild_s": rebuild}))


if __name__ == "__main__":
    main()
