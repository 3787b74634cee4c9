#!/usr/bin/env bash
# Does a fresh virtualenv with only the wheel run every command of the README and the docs?
# (issue 34, "Done when"; the last run is reported in results/wheel_check.md.)
#
#   bash benchmarks/wheel_check.sh [WORK]        # WORK: a scratch folder (default /tmp/wheel_check)
#   REUSE=1 bash benchmarks/wheel_check.sh WORK  # again, with the clone and virtualenvs of WORK
#
# 1. Clones this repository's HEAD (committed work only) into WORK/repo and builds the wheel.
# 2. Virtualenvs outside the repository, installed as the docs say:
#    WORK/venv       torch==2.13.0 first (the local CPU wheel here; DESIGN.md, torch pitfall),
#                    then the wheel with [train,sim,viz] (docs/index.md), then [all], then
#                    rl_zoo3 (docs/getting-started/agents.md, RL Zoo);
#    WORK/venv-core  the wheel alone (`pip install modquad_gym`, docs/index.md);
#    WORK/venv-repo  made by the README's own first command in the clone (requirements.txt and
#                    an editable install), for the commands the docs run from a clone
#                    (train.py, benchmarks/, mkdocs).
# 3. Every command line of the bash blocks of README.md, docs/*.md and docs/getting-started/*.md:
#    the package's commands from an empty folder per page (WORK/run/PAGE), so no repository file
#    is at hand; long ones shortened by their own documented options (fewer steps, fewer tasks,
#    a time limit); the few that cannot run here are listed as skipped with the reason.
# 4. Every page's python blocks, in order in one namespace (as tests/test_docs.py does, but with
#    the installed wheel), from an empty folder.
# 5. Coverage: every command line of the docs must be one that a check below names; a command
#    added to the docs without a check here fails the run.
#
# Writes WORK/commands.tsv (where, page, exit code, expected, seconds, the docs command, the
# command run where it differs) and a log per
# command in WORK/logs/; exits 1 when a command's exit code is not the expected one or a docs
# command is not covered. Needs python3 (3.10+) with `build`, git and curl; no GPU.
set -uo pipefail

REPO=$(cd "$(dirname "$0")/.." && pwd)
WORK=$(mkdir -p "${1:-/tmp/wheel_check}" && cd "${1:-/tmp/wheel_check}" && pwd)
LIMIT=${CMD_LIMIT:-1800}  # seconds any one command may take
PY=${PYTHON:-python3}
LOGS=$WORK/logs
TSV=$WORK/commands.tsv
COVERED=$WORK/covered.txt
export PIP_DISABLE_PIP_VERSION_CHECK=1 PIP_ROOT_USER_ACTION=ignore NO_MKDOCS_2_WARNING=1

if [[ ${REUSE:-0} != 1 ]]; then
  rm -rf "$WORK/repo" "$WORK/dist" "$WORK/venv" "$WORK/venv-core" "$WORK/venv-repo"
else  # the clone back to its commit (the virtualenvs stay)
  git -C "$WORK/repo" checkout -q -- . && git -C "$WORK/repo" clean -fdq && rm -rf "$WORK/repo/runs"
fi
rm -rf "$LOGS" "$TSV" "$COVERED" "$WORK/run" "$WORK/scale" "$WORK/my_board" "$WORK/site"
mkdir -p "$LOGS" "$WORK/run"
printf 'where\tpage\trc\texpected\tseconds\tdocs command\tcommand run (when shortened)\n' > "$TSV"
FAILED=0
N=0

norm() {  # a docs command without its trailing comment, whitespace collapsed
  sed -E 's/[[:space:]]+#[[:space:]].*$//; s/[[:space:]]+/ /g; s/^ //; s/ $//' <<< "$1"
}

record() {  # record WHERE PAGE RC EXPECTED SECONDS DOCS_COMMAND RUN_COMMAND
  local doc=${6//$'\t'/ } run=${7//$'\t'/ } mark=ok
  doc=${doc//$'\n'/ ; } run=${run//$'\n'/ ; }
  [[ $run == "$doc" ]] && run=""
  printf '%s\t%s\t%s\t%s\t%s\t%s\t%s\n' "$1" "$2" "$3" "$4" "$5" "$doc" "$run" >> "$TSV"
  [[ $3 == skip ]] && mark=skip
  [[ $3 != skip && $3 != "$4" ]] && { mark=FAIL; FAILED=1; }
  printf '%-4s %4s %7ss  %-6s %s\n' "$mark" "$3" "$5" "$1" "${doc:0:160}"
}

# check WHERE PAGE 'DOCS COMMAND' ['COMMAND RUN' ['EXPECTED EXIT CODE']]
#   WHERE: wheel (WORK/venv, WORK/run/PAGE), core (WORK/venv-core, WORK/run/core-PAGE) or repo
#   (WORK/venv-repo, in the clone). The docs command counts as covered; the run command (the
#   docs command itself when not given) runs with bash under a time limit.
check() {
  local where=$1 page=$2 doc=$3 cmd=${4:-$3} expect=${5:-0} dir venv
  norm "$doc" >> "$COVERED"
  case $where in
    wheel) venv=$WORK/venv; dir=$WORK/run/${page//\//_} ;;
    core) venv=$WORK/venv-core; dir=$WORK/run/core-${page//\//_} ;;
    repo) venv=$WORK/venv-repo; dir=$WORK/repo ;;
  esac
  mkdir -p "$dir"
  N=$((N + 1))
  local log=$LOGS/$(printf '%03d' $N).log start end rc
  echo "\$ $cmd   (in $dir)" > "$log"
  start=$(date +%s.%N)
  (cd "$dir" && PATH=$venv/bin:$PATH VIRTUAL_ENV=$venv WORK=$WORK REPO=$WORK/repo \
     timeout "$LIMIT" bash -c "$cmd") >> "$log" 2>&1
  rc=$?
  end=$(date +%s.%N)
  record "$where" "$page" "$rc" "$expect" "$(awk "BEGIN {printf \"%.1f\", $end - $start}")" "$doc" "$cmd"
  [[ $rc != "$expect" ]] && tail -5 "$log" | sed 's/^/       | /'
  return 0
}

skip() {  # skip PAGE 'DOCS COMMAND' 'REASON'
  norm "$2" >> "$COVERED"
  record - "$1" skip - 0 "$2" "skipped: $3"
}

# --- 1 and 2: the wheel and the virtualenvs ---------------------------------------------------
WHEEL_GLOB="$WORK/dist/modquad_gym-*.whl"
if [[ ${REUSE:-0} != 1 ]]; then
  git clone -q "$REPO" "$WORK/repo" || exit 1
  echo "clone: $(git -C "$WORK/repo" log --oneline -1 | cut -c1-100)"
  start=$(date +%s)
  (cd "$WORK/repo" && $PY -m build --wheel --outdir "$WORK/dist") > "$LOGS/build.log" 2>&1 \
    || { echo "the wheel does not build: $LOGS/build.log"; exit 1; }
  echo "wheel: $(basename $WHEEL_GLOB) ($(($(date +%s) - start)) s)"
  for v in venv venv-core venv-repo; do $PY -m venv "$WORK/$v" || exit 1; done
fi
WHEEL=$(echo $WHEEL_GLOB)
export WHEEL
echo "commands (ok | FAIL | skip, exit code, seconds, where, command):"
if [[ ${REUSE:-0} != 1 ]]; then  # the wheel named by its file (the package is not on a registry)
  check wheel install 'pip install torch==2.13.0'
  check wheel docs/index.md 'pip install "$WHEEL[train,sim,viz]"'
  check wheel install 'pip install "$WHEEL[all]"'
  check wheel install 'pip install rl_zoo3'
  check core docs/index.md 'pip install "$WHEEL"'
else
  for c in 'pip install "$WHEEL[train,sim,viz]"' 'pip install "$WHEEL"'; do norm "$c" >> "$COVERED"; done
fi
# step 1 built the wheel and named it; [train] is a subset of [train,sim,viz], installed above
for c in 'python -m build --wheel' 'WHEEL=$(ls dist/modquad_gym-*.whl)' 'pip install "$WHEEL[train]"'; do
  norm "$c" >> "$COVERED"
done
skip docs/index.md 'pip install torch --index-url https://download.pytorch.org/whl/cpu' \
  'download.pytorch.org is not reachable here; torch==2.13.0 is the local CPU wheel'

# --- 3: the docs' commands, from an empty folder per page -----------------------------------
# README.md: its first command makes the clone's environment (requirements.txt, editable).
T='python train.py'
check repo README.md 'pip install -r requirements.txt && pip install --no-deps -e . && python train.py' \
  'pip install -r requirements.txt && pip install --no-deps -e . && python train.py --quick --no-progress'
check repo README.md 'pip install -r requirements.txt && pip install --no-deps -e . && ruff check . && ruff format --check . && pytest' \
  'pip install -r requirements.txt && pip install --no-deps -e . && ruff check . && ruff format --check . && pytest -p no:cacheprovider tests/test_packaging.py'
skip README.md 'pip install torch==2.13.0 --index-url https://download.pytorch.org/whl/cpu && pip install -r requirements.txt && pip install --no-deps -e .' \
  'download.pytorch.org is not reachable here (the rest is the command above)'
for c in 'modquad solve --task example:screwdriver' \
         'modquad task generate --kind planted --n-modules 50 --seed 3 --out big.json' \
         'modquad solve --task big.json --n-max 64 --time-limit 60' \
         'modquad solve --task example:planted_seed1 --method ppo' \
         'modquad show --task example:screwdriver --html structure.html' \
         'modquad export --task example:screwdriver --out screwdriver.urdf' \
         'modquad validate --task example:screwdriver --out validation/' \
         'modquad task motion --kind circle --radius 1 --speed 2 --payload-mass 0.2 --out circle.json' \
         'modquad solve --task circle.json --n-max 8' \
         'modquad validate --task circle.json --out flight/' \
         'modquad solve --task example:screwdriver --fault rotor' \
         'modquad validate --task example:screwdriver --fault rotor --out fault/' \
         'modquad solve --task example:screwdriver --certificate proof.json.gz && modquad check proof.json.gz'; do
  check wheel README.md "$c"
done
check wheel README.md 'modquad solve --task big.json --n-max 64 --time-limit 60 --workers 2' \
  'modquad solve --task big.json --n-max 64 --time-limit 20 --workers 2'
# mkdocs serve: served, then stopped (a free port instead of 8000)
SERVE='port=$(python -c "import socket; s=socket.socket(); s.bind((\"127.0.0.1\", 0)); print(s.getsockname()[1])")
mkdocs serve -a 127.0.0.1:$port & pid=$!
ok=1; for i in $(seq 150); do curl -sf http://127.0.0.1:$port/ > /dev/null && { ok=0; break; }; sleep 2; done
kill $pid; wait $pid; exit $ok'
check repo README.md 'mkdocs serve' "$SERVE"
norm 'mkdocs serve' >> "$COVERED"
check repo README.md 'mkdocs build --strict' 'mkdocs build --strict --site-dir "$WORK/site"'

# docs/getting-started/design.md
for c in 'modquad task example' \
         'modquad solve --task example:screwdriver' \
         'modquad solve --task example:paper_seed0 --method centrosymmetric --json' \
         'modquad solve --task example:planted_seed1 --method ppo' \
         'modquad task example screwdriver --out screwdriver.json' \
         'modquad task generate --kind planted --seed 3 --out my_task.json' \
         'modquad show --task example:screwdriver --out structure.png' \
         'modquad show --task example:screwdriver --html structure.html' \
         'modquad export --task example:screwdriver --format urdf --out screwdriver.urdf' \
         'modquad validate --task example:screwdriver --out validation/'; do
  check wheel docs/getting-started/design.md "$c"
done

# docs/getting-started/agents.md: my_agent.py is the page's LineAgent block, saved as it says
cat > "$WORK/save_agent.py" <<'PY'
import re, sys
blocks = re.findall(r"^```python\n(.*?)^```", open(sys.argv[1]).read(), re.S | re.M)
open("my_agent.py", "w").write(next(b for b in blocks if "class LineAgent" in b))
PY
AGENT='python "$WORK/save_agent.py" "$REPO/docs/getting-started/agents.md"'
P=docs/getting-started/agents.md
check wheel $P 'python -m rl_zoo3.train --algo ppo --env ModQuadAssembly-v0 --gym-packages modquad_gym --conf-file "$(python -c '"'"'from modquad_gym.envs.wrappers import RL_ZOO_CONFIG; print(RL_ZOO_CONFIG)'"'"')"' \
  'python -m rl_zoo3.train --algo ppo --env ModQuadAssembly-v0 --gym-packages modquad_gym --conf-file "$(python -c '"'"'from modquad_gym.envs.wrappers import RL_ZOO_CONFIG; print(RL_ZOO_CONFIG)'"'"')" -n 1024'
check wheel $P 'modquad score --solver my_agent:LineAgent --limit 5 --out my_scores' \
  "$AGENT && modquad score --solver my_agent:LineAgent --limit 5 --out my_scores"
norm 'pip install -r requirements.txt && pip install --no-deps -e .' >> "$COVERED"  # README's, above
norm "$T" >> "$COVERED"  # the README's first command ran it (--quick)
check repo $P 'python train.py --tier large' "$T --tier large --quick --no-report --no-progress --out runs/large-quick"
check repo $P 'python train.py --seeds 0 1 2 3 4' "$T --seeds 0 1 --quick --no-report --no-progress --out runs/ppo-seeds"

# docs/leaderboard.md and results.md's leaderboard: before the benchmarks below replace reports
check repo docs/leaderboard.md 'python -m benchmarks.leaderboard --solver my_agent:Agent --out my_board' \
  "$AGENT && echo 'Agent = LineAgent' >> my_agent.py && python -m benchmarks.leaderboard --solver my_agent:Agent --out \"\$WORK/my_board\" --limit 1 --no-progress; rc=\$?; rm my_agent.py; exit \$rc"
P=docs/results.md
check repo $P 'python -m benchmarks.leaderboard --force'

# docs/leaderboard.md: a leaderboard row from the wheel (no clone): a tiny outside agent scored by
# `modquad score`, with a seed; and the fault tier's held-out suite shipped in the wheel
check wheel docs/leaderboard.md 'modquad score --tier current --solver my_agent:Agent --seed 0 --out my_scores' \
  "$AGENT && echo 'Agent = LineAgent' >> my_agent.py && modquad score --tier current --solver my_agent:Agent --seed 0 --out my_scores --limit 2 --no-progress && grep -q 'my_agent:Agent' my_scores/benchmark.md"
check wheel docs/leaderboard.md 'modquad score --tier fault --out fault_scores' \
  'modquad score --tier fault --out fault_scores --limit 2 --methods exhaustive greedy --no-progress'

# docs/benchmarks.md
P=docs/benchmarks.md
check repo $P 'python train.py --seeds 0 1 2 3 4 --no-report --out runs/seeds-current' \
  "$T --seeds 0 1 --quick --no-report --no-progress --out runs/seeds-current"
check repo $P 'python -m modquad_gym.scoring.seeds runs/seeds-current --tier current --out results/seeds_current --force' \
  'python -m modquad_gym.scoring.seeds runs/seeds-current --tier current --out results/seeds_current --force --limit 2 --no-progress'
check wheel $P 'modquad score --tier current --solver my_pkg.agent:Agent --out my_scores' \
  "$AGENT && mkdir -p my_pkg && touch my_pkg/__init__.py && echo 'from my_agent import LineAgent as Agent' > my_pkg/agent.py && modquad score --tier current --solver my_pkg.agent:Agent --out my_scores --limit 2"
check repo $P 'python -m benchmarks.scale --per-family 1 --time-limit 30 --force' \
  'python -m benchmarks.scale --per-family 1 --time-limit 5 --bands 16 --force'
check repo $P 'python -m benchmarks.scale --bands 16 24 --methods anytime greedy --time-limit 5 --out /tmp/scale' \
  'python -m benchmarks.scale --bands 16 24 --methods anytime greedy --time-limit 5 --out "$WORK/scale"'

# docs/distributed.md (big.json: the README's 50-module task)
P=docs/distributed.md
check wheel $P 'mkdir -p tasks && for s in 1 2 3 4; do modquad task generate --kind paper --seed $s --out tasks/t$s.json; done' \
  'mkdir -p tasks && for s in 1 2 3 4; do modquad task generate --kind paper --seed $s --out tasks/t$s.json; done'
check wheel $P 'modquad solve --task tasks/ --workers 2 --json' \
  'for s in 1 2 3; do modquad task generate --kind planted --seed $s --out tasks/t$s.json --force; done && modquad solve --task tasks/ --workers 2 --json'
check wheel $P 'modquad solve --task big.json --method exhaustive --n-max 14 --workers 2' \
  'modquad task generate --kind planted --n-modules 50 --seed 3 --out big.json && modquad solve --task big.json --method exhaustive --n-max 14 --workers 2'
check wheel $P 'modquad solve --task big.json --n-max 64 --time-limit 60 --workers 2' \
  'modquad solve --task big.json --n-max 64 --time-limit 20 --workers 2'
check wheel $P 'modquad optima --suite heldout_paper --out optima.jsonl'
norm 'python train.py --seeds 0 1 2 3 4' >> "$COVERED"  # agents.md's, above
# a cluster on this host as the page says (shared token), its driver commands, then stopped
CLUSTER='export RAY_AUTH_MODE=token RAY_AUTH_TOKEN=$(python -c "import secrets; print(secrets.token_hex(16))")
port=$(python -c "import socket; s=socket.socket(); s.bind((\"127.0.0.1\", 0)); print(s.getsockname()[1])")
ray start --head --port=$port --num-cpus=2 --include-dashboard=false --disable-usage-stats --block > head.log 2>&1 & head=$!
trap "kill $head 2> /dev/null" EXIT
for i in $(seq 60); do python -c "import ray; ray.init(address=\"127.0.0.1:$port\", logging_level=\"ERROR\")" 2> /dev/null && break; sleep 2; done
RAY_ADDRESS=127.0.0.1:$port modquad optima --task "tasks/*.json" --out optima-cluster.jsonl --quiet; a=$?
RAY_ADDRESS=127.0.0.1:$port modquad solve --task tasks/ --json; b=$?
kill $head; wait $head; exit $((a + b))'
check wheel $P "RAY_ADDRESS=HEAD_IP:6379 modquad optima --task 'tasks/*.json' --out optima.jsonl" "$CLUSTER"
for c in "export RAY_AUTH_MODE=token RAY_AUTH_TOKEN=\$(python -c 'import secrets; print(secrets.token_hex(16))')" \
         'ray start --head --port=6379' 'RAY_ADDRESS=HEAD_IP:6379 modquad solve --task tasks/ --json'; do
  norm "$c" >> "$COVERED"  # the cluster check above runs them
done

# docs/dynamics.md
P=docs/dynamics.md
for c in 'modquad task motion --kind circle --radius 1 --speed 2 --out circle.json' \
         'modquad task motion --kind figure-eight --speed 1 --payload-mass 0.4 --payload-offset 0,0,-0.1 --out eight.json' \
         'modquad solve --task circle.json --method exhaustive --n-max 8 --json'; do
  check wheel $P "$c"
done
check wheel $P 'modquad score --tier dynamic --out results/tier_dynamic --force' \
  'modquad score --tier dynamic --out results/tier_dynamic --force --limit 1'

# docs/export.md, faults.md, heterogeneous.md, learned-designer.md
for c in 'modquad export --task example:screwdriver --format mjcf --out screwdriver.xml' \
         'modquad export --task example:screwdriver --f-max 2.1 --out flying.xml' \
         "modquad export --cells '[[0,0],[1,0],[0,1]]' --modules t45,flat,t45m --out mixed.urdf" \
         'modquad solve --task example:paper_seed0 --export paper_seed0.json'; do
  check wheel docs/export.md "$c"
done
# exports that fly: the MJCF at 2.1 N per rotor hovers on its own rotors with the package's
# controller and no external load; at the default 1 N the command warns and the robot sinks
FLY='from modquad_gym.sim.export_flight import fly_mjcf
up, down = fly_mjcf("flying.xml"), fly_mjcf("screwdriver.xml")
print("2.1 N:", up.to_dict()); print("1 N:", down.to_dict())
assert up.thrust_to_weight > 2 and up.final_position_error_m < 0.01 and up.saturated_fraction == 0
assert down.thrust_to_weight < 1 and down.final_position_error_m > 0.1'
check wheel docs/export.md 'exports fly: fly_mjcf(flying.xml) holds its place, fly_mjcf(screwdriver.xml) sinks' \
  "modquad export --task example:screwdriver --f-max 2.1 --out flying.xml --force | grep -q 'it hovers' && modquad export --task example:screwdriver --out screwdriver.xml --force 2>&1 | grep -q 'warning: this robot cannot hover' && python -c '$FLY'"
# the URDF in MuJoCo as a floating robot (urdf_spec adds the free joint) and in yourdfpy
URDF='import mujoco, numpy as np, yourdfpy
import modquad_gym as mq
from modquad_gym.sim.export import urdf_spec
model = urdf_spec("screwdriver.urdf").compile()
data = mujoco.MjData(model)
mujoco.mj_forward(model, data)
assert model.jnt_type[0] == mujoco.mjtJoint.mjJNT_FREE and model.nq == 7 + 12
assert abs(model.body_subtreemass[1] - 0.9) < 1e-9 and np.abs(data.subtree_com[1]).max() < 1e-12
assert (model.geom_contype != 0).sum() == 3 + 12  # collision boxes and propeller discs
mujoco.mj_step(model, data, nstep=100)
assert data.qpos[2] < -0.19  # it falls: a floating base
robot = yourdfpy.URDF.load("screwdriver.urdf", load_meshes=False)
assert robot.validate() and robot.base_link == "base_link" and len(robot.joint_map) == 12
print("URDF floats in MuJoCo:", model.nq, "qpos,", model.ngeom, "geoms; yourdfpy:", len(robot.link_map), "links")'
check wheel docs/export.md 'URDF in MuJoCo: urdf_spec(screwdriver.urdf) floats, with inertials and collisions; yourdfpy reads it' \
  "modquad export --task example:screwdriver --out screwdriver.urdf --force && python -c '$URDF'"
for c in 'modquad solve --task example:screwdriver --fault rotor' \
         'modquad solve --task example:screwdriver --fault module --json' \
         'modquad validate --task example:screwdriver --fault rotor --out fault/' \
         'modquad solve --task example:screwdriver --fault rotor --fault-margin 0.05 --json' \
         'modquad solve --task example:screwdriver --fault rotor --detection-delay 0.02' \
         'modquad validate --task example:screwdriver --fault rotor --detection-delay 0.05 --out v/' \
         'modquad validate --task example:screwdriver --fault rotor --detection-delay 0.05 --detect --out v2/'; do
  check wheel docs/faults.md "$c"
done
# docs/certificates.md: a certificate written, checked by the command and by the checker alone
# (as the page says, its three files copied into a folder of their own)
P=docs/certificates.md
for c in 'modquad task example screwdriver --out task.json' \
         'modquad solve --task task.json --method exhaustive --certificate task_proof.json.gz' \
         'modquad check task_proof.json.gz' 'modquad check task_proof.json.gz --levels'; do
  check wheel $P "$c"
done
check wheel $P 'python modquad_gym/proofcheck.py task_proof.json.gz' \
  'mkdir -p alone && cp "$(python -c "import modquad_gym; print(modquad_gym.__path__[0])")"/proofcheck*.py alone/ && cd alone && python proofcheck.py ../task_proof.json.gz'
for c in 'modquad solve --task example:paper_seed0 --modules t45,t45m,flat --json' \
         'modquad task generate --kind planted --task-kind external --seed 2 --out ext.json' \
         "modquad show --cells '[[0,0],[1,0],[0,1]]' --modules t45,flat,t45m --out mixed.png"; do
  check wheel docs/heterogeneous.md "$c"
done
check repo docs/heterogeneous.md 'python -m benchmarks.heterogeneous --force' \
  'python -m benchmarks.heterogeneous --force --tasks 2 --mujoco 1'
for c in 'modquad solve --task example:planted_seed1 --method ppo' \
         'modquad solve --task example:planted_seed1 --method ppo-guided' \
         'modquad solve --task example:paper_seed0 --method ppo --modules t45,t45m,flat' \
         'modquad solve --task example:planted_seed1 --method ppo --n-max 64 --option extra_fallbacks=' \
         'modquad solve --task example:screwdriver --method ppo --fault rotor'; do
  check wheel docs/learned-designer.md "$c"
done
skip docs/learned-designer.md 'python -m agents.expert_iteration --rounds 2 --out runs/exit' \
  'two rounds of expert iteration at 8-32 modules take 14-30 min of training (the page says so)'
skip docs/learned-designer.md 'cp runs/exit/model.zip runs/exit/model_actor.npz runs/exit/config.json modquad_gym/data/models/ppo_scale/' \
  'replaces the shipped scale model on purpose, after the command above'

# docs/index.md: the clone's environment and the site (the README's commands, above)
for c in 'pip install torch==2.13.0 --index-url https://download.pytorch.org/whl/cpu && pip install -r requirements.txt && pip install --no-deps -e .' \
         'mkdocs build --strict'; do
  norm "$c" >> "$COVERED"
done

# docs/results.md (the reports' commands: from the clone; the leaderboard above)
P=docs/results.md
check wheel $P 'modquad score --tier large --out results/tier_large --force' \
  'modquad score --tier large --out results/tier_large --force --limit 1'
norm 'python train.py --seeds 0 1 2 3 4 --no-report --out runs/seeds-current' >> "$COVERED"
check repo $P 'python -m benchmarks.oracle --structures 20 --wrenches 80 --seed 0 --repeats 3 --modules 7,10,16,32,64 --force' \
  'python -m benchmarks.oracle --structures 2 --wrenches 20 --seed 0 --repeats 1 --modules 7,16 --force'
check repo $P 'python -m benchmarks.paper --seeds 10 --force' 'python -m benchmarks.paper --seeds 2 --force'
check repo $P 'python -m benchmarks.heterogeneous --tasks 25 --seed 0 --n-max 7 --force' \
  'python -m benchmarks.heterogeneous --tasks 2 --seed 0 --n-max 7 --mujoco 1 --force'
check repo $P 'python -m benchmarks.env --force' \
  'python -m benchmarks.env --force --steps 200 --warmup 20 --default-steps 200 --scale 16 --scale-steps 20 --scale-warmup 5 --no-ppo'
# last: it replaces the clone's shipped model by a quick seed's
check repo docs/benchmarks.md 'python train.py --publish-run runs/seeds-current/seed-0' "$T --publish-run runs/seeds-current/seed-0 --no-progress"

# a few commands with the bare wheel (the core): what needs an extra says which, in one line
for c in 'modquad solve --task example:screwdriver' 'modquad solve --task example:paper_seed0 --method centrosymmetric --json' \
         'modquad export --task example:screwdriver --out screwdriver.urdf'; do
  check core docs/index.md "$c"
done
# the shipped models act without torch (their NumPy actors); a model without one needs [train]
check core docs/index.md 'modquad solve --task example:planted_seed1 --method ppo'
check core docs/index.md 'modquad solve --task example:planted_seed1 --method ppo --model model.zip' \
  'cp "$(python -c "from modquad_gym.policy.models import DEFAULT_MODEL as m; print(m)")" model.zip && modquad solve --task example:planted_seed1 --method ppo --model model.zip 2> err; rc=$?; cat err; [ $rc = 2 ] && [ $(wc -l < err) = 1 ] && grep -q "modquad_gym.train" err'
# what needs an extra refuses before any work: exit 2, one line naming the extra, nothing
# printed or written (refuses.sh EXTRA COMMAND...)
cat > "$WORK/refuses.sh" <<'SH'
extra=$1; shift
tmp=$(mktemp -d); before=$(ls -A)
"$@" > "$tmp/out" 2> "$tmp/err"; rc=$?
cat "$tmp/err"
[ "$rc" = 2 ] && [ "$(wc -l < "$tmp/err")" = 1 ] && grep -q "modquad_gym\[$extra\]" "$tmp/err" \
  && [ ! -s "$tmp/out" ] && [ "$(ls -A)" = "$before" ]
SH
for c in 'sim modquad validate --task example:screwdriver --out validation/' \
         'sim modquad export --task example:screwdriver --format mjcf --out screwdriver.xml' \
         'sim modquad solve --task example:paper_seed0 --export paper_seed0.xml' \
         'viz modquad show --task example:screwdriver --out structure.png' \
         'viz modquad show --task example:screwdriver --html structure.html'; do
  check core extras "${c#* }" "bash \"\$WORK/refuses.sh\" $c"
done

# --- 4: the python blocks, a page at a time, with the wheel ---------------------------------
cat > "$WORK/run_blocks.py" <<'PY'
import re, sys
text = open(sys.argv[1]).read()
namespace = {"__name__": "__docs__"}
for i, block in enumerate(re.findall(r"^```python\n(.*?)^```", text, re.S | re.M)):
    exec(compile(block, f"{sys.argv[1]} python block {i + 1}", "exec"), namespace)
PY
for page in $(cd "$WORK/repo" && ls README.md docs/*.md docs/getting-started/*.md); do
  grep -q '^```python$' "$WORK/repo/$page" || continue
  check wheel "$page" "python blocks of $page" "python \"\$WORK/run_blocks.py\" \"\$REPO/$page\""
done

# --- 5: coverage ------------------------------------------------------------------------------
UNCOVERED=$($PY - "$WORK/repo" "$COVERED" <<'PY'
import re, sys
from pathlib import Path
root, covered = Path(sys.argv[1]), set(Path(sys.argv[2]).read_text().splitlines())
pages = [root / "README.md", *sorted(root.glob("docs/*.md")), *sorted(root.glob("docs/getting-started/*.md"))]
for page in pages:
    for block in re.findall(r"^```(?:bash|sh|shell|console)[^\n]*\n(.*?)^```", page.read_text(), re.S | re.M):
        for line in block.replace("\\\n", " ").splitlines():
            line = " ".join(re.sub(r"\s+#\s.*$", "", line).split())
            if line and not line.startswith("#") and line not in covered:
                print(f"{page.relative_to(root)}: {line}")
PY
)
if [[ -n $UNCOVERED ]]; then
  FAILED=1
  echo "docs commands that no check covers (add one to benchmarks/wheel_check.sh):"
  echo "$UNCOVERED" | sed 's/^/  /'
fi
echo "$(($(wc -l < "$TSV") - 1)) commands; table: $TSV; logs: $LOGS"
[[ $FAILED == 0 ]] && echo "wheel check: every command as expected" || echo "wheel check: FAILED"
exit $FAILED
