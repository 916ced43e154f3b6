"""numba's inliner copies an inlined kernel's IR with one memo for all its
blocks (wmr_mission.kernels.jit._inlined_copies_share_their_scope): the
callee's scope once per copy, not once per block. The results are the same
here, and every compiled run of the suite is checked against plain Python
and against pinned trajectories."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from importlib import metadata
from pathlib import Path

import pytest

from wmr_mission.kernels import jit

# 40 branches: some 80 blocks, each naming the kernel's scope of 100 variables;
# inlined at two call sites, and inlining a kernel of its own.
BRANCHES = 40
KERNELS = (
    "from wmr_mission.kernels.jit import inlined\n\n\n"
    "@inlined\ndef scaled(x, k):\n    if x > k:\n        return x * k\n    return x - k\n\n\n"
    "@inlined\ndef branchy(x):\n    total = scaled(x, 2.0)\n"
    + "".join(
        f"    if x > {i}.5:\n        part_{i} = x * {i + 1}.0\n        total += part_{i}\n"
        for i in range(BRANCHES)
    )
    + "    return total\n\n\ndef entry(x):\n    return branchy(x) - branchy(x + 1.0)\n"
)

COUNT = """
import copy, json, sys
from numba.core import inline_closurecall, ir
from wmr_mission.kernels import jit

copied = [0]
var_deepcopy = ir.Var.__deepcopy__

def counting(self, memo):
    copied[0] += 1
    return var_deepcopy(self, memo)

ir.Var.__deepcopy__ = counting
import shared_scope, own_scopes

found = {"plain": shared_scope.entry(7.25)}  # its kernels called from Python: plain
found["shared"] = jit.compiled(shared_scope.entry, cached=False)(7.25)
found["shared copies"] = copied[0]
inline_closurecall.copy = copy  # numba's own copying, a memo per block
copied[0] = 0
found["own"] = jit.compiled(own_scopes.entry, cached=False)(7.25)
found["own copies"] = copied[0]
print(json.dumps(found))
"""


@pytest.mark.skipif(
    not jit.compiling(), reason="numba is not installed or WMR_MISSION_NO_JIT is set"
)
def test_an_inlined_kernels_scope_is_copied_once_per_copy_not_per_block(
    tmp_path: Path,
) -> None:
    if metadata.version("numba").split(".")[:2] != jit.LOADED_AS_IS_FOR.split("."):
        pytest.skip(f"the inliner read is numba {jit.LOADED_AS_IS_FOR}'s")
    for name in ("shared_scope", "own_scopes"):  # the same kernel twice: compiled apart
        (tmp_path / f"{name}.py").write_text(KERNELS)
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(tmp_path), *sys.path])}
    done = subprocess.run(
        [sys.executable, "-c", COUNT], env=env, capture_output=True, text=True, check=False
    )
    assert done.returncode == 0, done.stderr
    found = json.loads(done.stdout.splitlines()[-1])
    assert found["shared"] == found["own"] == found["plain"]
    # numba's own: every block copies the scope's variables again.
    assert found["own copies"] > 10 * found["shared copies"], found
