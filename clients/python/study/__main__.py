"""python3 -m coopdyn.study SPEC.yaml --out FILE.csv [--workers N | --scheduler ADDRESS] [--resume]"""
import argparse
import sys

from .run import run
from .spec import StudyError


def main(argv=None):
    p = argparse.ArgumentParser(prog="coopdyn study", description="Run a study (sweep or Monte Carlo) of a scene "
                                "on Dask; one CSV row per sample (docs/guide/studies.md).")
    p.add_argument("spec", help="the study file (YAML)")
    p.add_argument("--out", required=True, help="the result (CSV): the commit and the spec in its '#' header")
    g = p.add_mutually_exclusive_group()
    g.add_argument("--workers", type=int, default=None,
                   help="N local worker processes (a Dask LocalCluster; default one per core); 0: in this process")
    g.add_argument("--scheduler", help="the address of a running Dask scheduler, tcp://HOST:PORT")
    p.add_argument("--resume", action="store_true", help="continue the --out file after its last whole chunk")
    p.add_argument("--progress", action="store_true", default=None, help="a progress bar on stderr "
                   "(the default when stderr is a terminal)")
    a = p.parse_args(argv)
    if a.workers is not None and a.workers < 0:
        p.error("--workers: 0 (in this process) or more")
    progress = sys.stderr.isatty() if a.progress is None else a.progress
    try:
        run(a.spec, out=a.out, workers=a.workers, scheduler=a.scheduler, resume=a.resume, progress=progress)
    except StudyError as e:
        print(f"coopdyn study: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"\ncoopdyn study: interrupted; {a.out} ends on a whole chunk: --resume continues it",
              file=sys.stderr)
        return 130
    return 0


if __name__ == "__main__":
    sys.exit(main())
