"""coopdyn.study: sweeps and Monte Carlo studies of a scene, on Dask (docs/guide/studies.md).

    from coopdyn import study
    study("config/studies/payload_two_puma.yaml", out="payload.csv", workers=2)   # = study.run(...)
    python3 -m coopdyn.study SPEC.yaml --out FILE.csv [--workers N | --scheduler tcp://HOST:PORT] [--resume]
"""
import sys
import types

from .spec import StudyError, load
from .run import run

__all__ = ["StudyError", "load", "run"]


class _CallableModule(types.ModuleType):
    def __call__(self, *args, **kwargs):
        return run(*args, **kwargs)


sys.modules[__name__].__class__ = _CallableModule
