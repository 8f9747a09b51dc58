"""BLAS runs on one thread unless the user chose (manipcad._blas_threads)."""

import json
import os
import subprocess
import sys

PROBE = ("import json, numpy, manipcad, scipy.linalg\n"
         "from threadpoolctl import threadpool_info\n"
         "print(json.dumps(sorted({i['num_threads'] for i in threadpool_info() "
         "if i['user_api'] == 'blas'})))")


def _blas_threads(env_extra: dict) -> list[int]:
    env = {k: v for k, v in os.environ.items()
           if k not in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS",
                        "MANIPCAD_BLAS_THREADS")}
    env.update(env_extra)
    out = subprocess.run([sys.executable, "-c", PROBE], env=env, capture_output=True,
                         text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def test_one_blas_thread_after_import_even_when_numpy_came_first():
    # numpy is imported before manipcad in the probe: its BLAS is limited at run time,
    # scipy's (loaded after) by the environment
    assert _blas_threads({}) == [1]


def test_manipcad_blas_threads_asks_for_more():
    assert _blas_threads({"MANIPCAD_BLAS_THREADS": "2"}) == [2]


def test_the_users_own_choice_is_left_alone():
    assert _blas_threads({"OPENBLAS_NUM_THREADS": "2"}) == [2]
