"""The expert system that chooses synthesis methods (paper section 5, Fig. 1).

- :class:`Requirements`: what is asked of a drive's control and what the
  manipulator is like (accuracy, overshoot, fast action, gripper speed,
  inductance, transmission, coupling, parameter variation); a YAML file or a
  dict; the fields a robot and a trajectory determine can be derived.
- ``rules.yaml``: the rule base, as data (docs/expert-rules.md).
- :func:`recommend`: the ranked methods (most preferred by the rules, then
  least realization complexity), each with the rules that put it there, and
  the excluded methods with why; ``verify=True`` re-ranks by simulation.
"""

from manipcad.expert.engine import (
    METHODS,
    ContradictoryRequirements,
    IncompleteRequirements,
    Recommendation,
    Recommendations,
    RuleBase,
    load_rules,
    recommend,
)
from manipcad.expert.requirements import Derivation, Requirements, TransmissionFeatures, derive

__all__ = ["Requirements", "TransmissionFeatures", "recommend", "Recommendation",
           "Recommendations", "load_rules", "RuleBase", "IncompleteRequirements",
           "ContradictoryRequirements", "derive", "Derivation", "METHODS"]
