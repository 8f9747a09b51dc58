"""Reproductions of the paper's experiments.

- :func:`run_fig3`: the Fig. 3 study (turning drive of the Fig. 2 arm under
  laws (2); every synthesis method; figure, JSON and HTML report).
"""

from manipcad.study.fig3 import Fig3Result, run_fig3

__all__ = ["run_fig3", "Fig3Result"]
