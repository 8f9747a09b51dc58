"""Customized per-robot dynamics code: symbolic, cse'd, emitted as numba and as C99.

``gen = generate(robot)`` gives the robot's own inverse dynamics (drive terms
included), mass matrix, moment components H_ii, h_i, Q_i and forward
dynamics, with the operation counts of the generated code in ``gen.ops``;
``gen.c_code()`` the portable C. See docs/dynamics.md ("Customized code").
"""

from manipcad.codegen.generate import (
    CFUNC_SIGNATURES,
    MAX_JOINTS,
    GeneratedDynamics,
    c_identifier,
    cache_root,
    code_text,
    find,
    generate,
    robot_hash,
    simulation_kernels,
)

__all__ = ["generate", "GeneratedDynamics", "robot_hash", "c_identifier", "code_text", "cache_root",
           "MAX_JOINTS", "CFUNC_SIGNATURES", "find", "simulation_kernels"]
