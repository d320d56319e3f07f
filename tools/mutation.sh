#!/usr/bin/env bash
# Mutation testing with mutmut 3 (issue 42, build point 5). Not run by CI: it is slow.
#
# Usage: tools/mutation.sh MODULE [MUTANT_GLOB ...]
#   MODULE       domain | fallback | policy | features | lags | ols | conformal |
#                conformal_numerics | scale_factor | transition
#   MUTANT_GLOB  optional mutmut mutant names or globs to restrict the run to a subset,
#                e.g. 'sklearn_ifog.domain.x_fit_fallback__mutmut_*' (default: every mutant
#                of the module)
# Environment: MUTATION_DIR (scratch root), MUTATION_TESTS (test files instead of the
# module's default selection below), MUTMUT (the mutmut executable; default .venv/bin/mutmut),
# MUTATION_CHILDREN (mutants run at once; default 1, for a machine shared with other work).
#
# The working tree is never touched: its tracked and untracked (not ignored) files are copied
# to a scratch directory ($MUTATION_DIR/MODULE, default /tmp/sklearn-ifog-mutation/MODULE,
# wiped at each run), a [mutmut] section naming the module and the tests that exercise it is
# written there, and mutmut (which itself works on a copy, in mutants/) runs with one worker
# (MUTATION_CHILDREN) under `nice`. Each mutant runs only the selected tests that call the
# mutated function (mutmut records which they are), with pytest -x, so a killed mutant costs
# one failing test.
#
# At the end the script prints the score (killed / total) and writes every surviving mutant's
# diff to $MUTATION_DIR/MODULE/survivors.diff.
set -euo pipefail

repo=$(git -C "$(dirname "$0")" rev-parse --show-toplevel)
module=${1:?usage: tools/mutation.sh MODULE [MUTANT_GLOB ...]}
shift

case $module in
domain)
    source_file=sklearn_ifog/domain.py
    # The pipeline-level domain tests (test_conformal_domain.py, test_unitwise_domain.py,
    # test_streaming_domain.py, test_export_domain.py) are left out for speed: a mutant
    # only they would kill counts as a survivor here.
    tests="tests/test_domain.py tests/test_domain_threshold.py tests/test_domain_mutants.py"
    ;;
fallback)
    source_file=sklearn_ifog/fallback.py
    tests="tests/test_domain.py tests/test_domain_mutants.py"
    ;;
policy)
    source_file=sklearn_ifog/policy.py
    tests="tests/test_policy.py tests/test_domain.py tests/test_domain_mutants.py"
    ;;
features)
    source_file=sklearn_ifog/features.py
    tests="tests/test_features.py tests/test_lags.py tests/test_features_mutants.py"
    ;;
lags)
    source_file=sklearn_ifog/_lags.py
    tests="tests/test_lags.py tests/test_features.py tests/test_lags_mutants.py"
    ;;
ols)
    source_file=sklearn_ifog/rbf/_ols.py
    tests="tests/test_ols.py tests/test_ols_mutants.py"
    ;;
conformal_numerics)
    source_file=sklearn_ifog/_conformal_numerics.py
    tests="tests/test_conformal.py tests/test_conformal_mutants.py"
    ;;
scale_factor)
    source_file=sklearn_ifog/scale_factor.py
    # The deployment tests (C compiled per case) are left out for speed.
    tests="tests/test_scale_factor.py tests/test_scale_factor_mutants.py"
    ;;
transition)
    source_file=sklearn_ifog/_transition.py
    tests="tests/test_transition_terms.py tests/test_transition_mutants.py"
    ;;
conformal)
    source_file=sklearn_ifog/conformal.py
    tests="tests/test_conformal.py tests/test_conformal_domain.py tests/test_conformal_mutants.py"
    ;;
*)
    echo "tools/mutation.sh: unknown module '$module' (expected domain, fallback, policy, features, lags, ols, conformal, conformal_numerics, scale_factor or transition)" >&2
    exit 2
    ;;
esac

tests=${MUTATION_TESTS:-$tests} # a test selection of one's own, e.g. to measure a suite before
mutmut=${MUTMUT:-$repo/.venv/bin/mutmut}
[ -x "$mutmut" ] || mutmut=$(command -v mutmut)
work=${MUTATION_DIR:-${TMPDIR:-/tmp}/sklearn-ifog-mutation}/$module
rm -rf "$work"
mkdir -p "$work"

# A snapshot of the working tree (a file deleted but not yet committed is skipped).
(cd "$repo" && git ls-files -z -c -o --exclude-standard) |
    (cd "$repo" && tar --null --ignore-failed-read -T - -cf - 2>/dev/null) |
    tar -xf - -C "$work"

{
    echo "[mutmut]"
    echo "source_paths = sklearn_ifog"
    echo "only_mutate = $source_file"
    echo "pytest_add_cli_args_test_selection ="
    for t in $tests; do
        [ -f "$work/$t" ] && echo "    $t"
    done
    printf '%s\n' "pytest_add_cli_args =" "    -m" "    not benchmark" "    -p" "    no:cacheprovider"
    # Workers forked from a process that ran the tests (pandas, polars and pyarrow start
    # threads) can deadlock on a lock held at the fork: features' mutants then stalled until
    # their timeout. A fork server that has only imported them forks clean workers.
    echo "process_isolation = forkserver"
    # A mutant that loops forever is stopped after this many times its tests' own time
    # (mutmut's default, 15, costs minutes of CPU per such mutant on a shared machine).
    echo "timeout_multiplier = 3.0"
} >"$work/setup.cfg"
# mutmut reads pyproject.toml's [tool.mutmut] before setup.cfg: this project keeps none.
if grep -q '^\[tool\.mutmut\]' "$work/pyproject.toml"; then
    echo "tools/mutation.sh: pyproject.toml has a [tool.mutmut] section; remove it" >&2
    exit 2
fi

cd "$work"
export OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 MKL_NUM_THREADS=1
nice -n 10 "$mutmut" run --max-children "${MUTATION_CHILDREN:-1}" "$@" || true

"$mutmut" results --all true >results.txt
# The score counts the mutants the run was asked for (every mutant of the module, or those
# matching the globs); a timeout counts as killed, "no tests" (no selected test calls the
# function) as not killed.
python=$(dirname "$mutmut")/python
[ -x "$python" ] || python=python3
"$python" - "$module" "$source_file" "$@" <<'PY' | tee score.txt
import collections
import fnmatch
import sys

module, source_file, *globs = sys.argv[1:]
status = {}
for line in open("results.txt"):
    name, _, state = line.strip().partition(": ")
    if state and (not globs or any(fnmatch.fnmatch(name, g) or name == g for g in globs)):
        status[name] = state
counts = collections.Counter(status.values())
killed = counts["killed"] + counts["timeout"]
total = len(status)
subset = " (subset: " + " ".join(globs) + ")" if globs else ""
print(
    f"{module} ({source_file}){subset}: killed {killed} / {total}"
    + (f" ({100 * killed / total:.1f} %)" if total else "")
    + "; "
    + ", ".join(f"{k} {v}" for k, v in sorted(counts.items()))
)
with open("survivors.txt", "w") as f:
    f.writelines(n + "\n" for n, s in sorted(status.items()) if s == "survived")
PY
# Every survivor's diff, in one process (a `mutmut show` per mutant reloads everything).
"$python" - "$source_file" <<'PY' >survivors.diff
import sys
from pathlib import Path

from mutmut.mutation.diff_apply import get_diff_for_mutant

for name in Path("survivors.txt").read_text().split():
    print(f"# {name}")
    print(get_diff_for_mutant(name, path=Path(sys.argv[1])))
PY
echo "survivors' diffs: $work/survivors.diff; every status: $work/results.txt"
