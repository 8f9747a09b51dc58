"""The automated design: requirements, robot and trajectories in; a verified design out.

``run_design`` (:mod:`.pipeline`) chains the steps: drives (:mod:`.drives`), decoupling
(:mod:`.decouple`), the rules' candidates (:mod:`.candidates`), the verification sweep
over payloads and parameter uncertainty (:mod:`.cases`, :mod:`.sweep`, :mod:`.judge`),
the decision (:mod:`.decide`) and the outputs (:mod:`.outputs`). docs/design.md.
"""

from manipcad.design.pipeline import DesignNotMet, run_design

__all__ = ["run_design", "DesignNotMet"]
