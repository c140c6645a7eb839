#!/usr/bin/env python3
"""Strong scaling of `softhom sweep` over MPI ranks (BENCHMARKS.md, "Campaigns over MPI").

    bench/sweep_mpi.py --softhom BUILD/apps/softhom [--ranks 1 2 4] [--repeat 3] [--work DIR]
                       [--campaign bench/campaign_mpi64.toml]

Runs the campaign into a fresh --out for every rank count and repetition, with one OpenMP thread per
rank (OMP_NUM_THREADS=1, passive waits) and one job per rank, under
`mpirun --allow-run-as-root --oversubscribe -n R` (R = 1 is the one-process program: MPI with one rank
runs the serial path). Each run starts from the same FFTW wisdom (made once beforehand), so planning
does not differ between runs. Prints one line per run and a Markdown table of medians: wall time,
cases/s, speed-up against 1 rank, the time rank 0 spent adding cases to the store and rewriting it
(summary.json store_time_s), and the load average before the runs. Rank counts above the core count
are oversubscribed and marked so.
"""
import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--softhom", type=Path, required=True)
    ap.add_argument("--mpirun", default="mpirun")
    ap.add_argument("--campaign", type=Path, default=HERE / "campaign_mpi64.toml")
    ap.add_argument("--ranks", type=int, nargs="+", default=[1, 2, 4])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--work", type=Path, default=Path("/tmp/softhom-bench-sweep-mpi"))
    a = ap.parse_args()
    env = dict(os.environ, OMP_NUM_THREADS="1", OMP_WAIT_POLICY="passive")
    softhom = str(a.softhom.resolve())
    if a.work.exists():
        shutil.rmtree(a.work)
    a.work.mkdir(parents=True)
    cores = os.cpu_count() or 1

    # FFTW wisdom for every grid of the campaign, made once (a throwaway one-process run).
    warm = a.work / "wisdom-run"
    subprocess.run([softhom, "sweep", str(a.campaign), "--out", str(warm), "-j", "1", "--jobs", "1", "-q"], env=env,
                   check=True)
    wisdom = warm / "fftw.wisdom"

    rows = {r: [] for r in a.ranks}
    for rep in range(a.repeat):
        for r in a.ranks:  # interleaved, so that a change of machine load hits every rank count alike
            out = a.work / ("r%d-%d" % (r, rep))
            out.mkdir()
            shutil.copy(wisdom, out / "fftw.wisdom")
            load = os.getloadavg()[0]
            cmd = [a.mpirun, "--allow-run-as-root", "--oversubscribe", "-n", str(r), softhom, "sweep", str(a.campaign),
                   "--out", str(out), "-j", "1", "--jobs", "1", "-q"]
            t0 = time.monotonic()
            p = subprocess.run(cmd, env=env, capture_output=True, text=True)
            wall = time.monotonic() - t0
            if p.returncode != 0:
                sys.exit("run failed (%d): %s\n%s" % (p.returncode, " ".join(cmd), p.stderr[-2000:]))
            s = json.loads((out / "summary.json").read_text())
            run = dict(wall=wall, cases=s["finished"], store=s["store_time_s"], load=load,
                       per_rank=s.get("cases_per_rank", [s["finished"]]), newton=s["newton_iterations"])
            rows[r].append(run)
            print("ranks %d rep %d: wall %.2f s, %d cases, store %.3f s, cases/rank %s, Newton %d, load %.1f"
                  % (r, rep, wall, run["cases"], run["store"], run["per_rank"], run["newton"], load), flush=True)

    base = statistics.median(x["wall"] for x in rows[a.ranks[0]])
    print("\n| ranks | wall (median; runs) | cases/s | speed-up | rank 0 store time | load before |")
    print("|---|---|---|---|---|---|")
    for r in a.ranks:
        walls = [x["wall"] for x in rows[r]]
        med = statistics.median(walls)
        cases = rows[r][0]["cases"]
        store = statistics.median(x["store"] for x in rows[r])
        loads = [x["load"] for x in rows[r]]
        label = "%d%s" % (r, " (oversubscribed)" if r > cores else "")
        print("| %s | %.1f s (%s) | %.2f | %.2f | %.2f s (%.0f %% of wall) | %.0f–%.0f |"
              % (label, med, ", ".join("%.1f" % w for w in walls), cases / med, base / med, store,
                 100 * store / med, min(loads), max(loads)))


if __name__ == "__main__":
    main()
