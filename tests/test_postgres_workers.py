"""Two `modesel worker` processes on one study in a real PostgreSQL server:
no trial is lost (every trial ends COMPLETE or FAIL) and no mode set is
simulated twice, and the counts each worker prints add up to the sets the
study simulated. The storage URL is the plain form the README gives
(``postgresql://user@127.0.0.1:PORT/db``, no driver named). The test starts a
throwaway cluster on loopback; it skips outside CI when PostgreSQL is not
installed (.ci/run installs it)."""
import glob
import os
import pwd
import shutil
import socket
import subprocess
import sys
import textwrap

import pytest

from modesel.simulation.api import load_scene, simulate


def _pg_bin(name):
    found = shutil.which(name)
    if found:
        return found
    cands = sorted(glob.glob(f"/usr/lib/postgresql/*/bin/{name}"))
    return cands[-1] if cands else None


def _free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture
def postgres(tmp_path):
    initdb, pg_ctl = _pg_bin("initdb"), _pg_bin("pg_ctl")
    if not (initdb and pg_ctl):
        if os.environ.get("CI"):
            pytest.fail("PostgreSQL is not installed (.ci/run should install it)")
        pytest.skip("PostgreSQL (initdb, pg_ctl) not installed; .ci/run installs it for CI")
    pytest.importorskip("psycopg2")
    import tempfile
    root = tempfile.mkdtemp(prefix="modesel-pg-")   # outside pytest's private (0700) tmp tree
    data = os.path.join(root, "pgdata")
    sock = os.path.join(root, "sock")
    os.mkdir(data)
    os.mkdir(sock)
    prefix = []
    if os.geteuid() == 0:                       # the server refuses to run as root
        user = "postgres" if _has_user("postgres") else "nobody"
        uid = pwd.getpwnam(user).pw_uid
        for p in (root, data, sock):
            os.chown(p, uid, -1)
        prefix = ["runuser", "-u", user, "--"]
    port = _free_port()
    subprocess.run(prefix + [initdb, "-D", str(data), "-A", "trust", "-U", "modesel"], check=True,
                   capture_output=True)
    subprocess.run(prefix + [pg_ctl, "-D", str(data), "-w", "-l", os.path.join(root, "pg.log"), "-o",
                             f"-p {port} -k {sock} -c listen_addresses=127.0.0.1", "start"],
                   check=True, capture_output=True)
    try:
        import psycopg2
        con = psycopg2.connect(host="127.0.0.1", port=port, user="modesel", dbname="postgres")
        con.autocommit = True
        con.cursor().execute("CREATE DATABASE study")
        con.close()
        yield f"postgresql://modesel@127.0.0.1:{port}/study"
    finally:
        subprocess.run(prefix + [pg_ctl, "-D", str(data), "-m", "immediate", "stop"], capture_output=True)
        shutil.rmtree(root, ignore_errors=True)


def _has_user(name):
    try:
        pwd.getpwnam(name)
        return True
    except KeyError:
        return False


def test_two_workers_share_a_study(postgres, tmp_path):
    work = tmp_path / "work"
    work.mkdir()
    os.chmod(tmp_path, 0o755)
    scene_src = os.path.abspath("studies/scenes/paper_2dof_tower_shaft.toml")
    ref = simulate(load_scene(scene_src), tmax=2.0, dt=0.05).outputs[["Time", "TTDspFA"]]
    ref.to_csv(work / "ref.csv", index=False)
    (work / "study.toml").write_text(textwrap.dedent(f"""
        [study]
        name = "pg_two_workers"
        [[scene]]
        path = "{scene_src}"
        tmax = 2.0
        dt = 0.05
        [reference]
        kind = "csv"
        path = "ref.csv"
        [compare]
        channels = ["TTDspFA"]
        tolerance = 1e-9
        [search.fields.tower_fa]
        families = ["clamped", "cosine", "polynomial"]
        max_count = 2
        [budget]
        n_trials = 3
        stop_when_met = false
        [run]
        seed = 1
        """))
    cmd = [sys.executable, "-m", "modesel", "worker", str(work / "study.toml"), "--storage", postgres,
           "--n-trials", "3"]
    procs = [subprocess.Popen(cmd, cwd=work, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
             for _ in range(2)]
    outs = [p.communicate(timeout=600) for p in procs]
    for p, (out, err) in zip(procs, outs):
        assert p.returncode == 0, err
    import re

    import optuna

    from modesel.study.search import open_storage
    study = optuna.load_study(study_name="pg_two_workers", storage=open_storage(postgres))
    trials = study.get_trials(deepcopy=False)
    states = {t.state for t in trials}
    assert states <= {optuna.trial.TrialState.COMPLETE, optuna.trial.TrialState.FAIL}, states
    simulated = [t.user_attrs["modeset"] for t in trials if "duplicate_of" not in t.user_attrs]
    assert len(simulated) == len(set(simulated)), simulated          # nothing simulated twice
    assert len(simulated) >= 6                                      # 3 per worker, none lost
    printed = [int(re.search(r": this worker evaluated (\d+) new mode sets", out).group(1)) for out, _ in outs]
    evaluated = [t for t in trials if "duplicate_of" not in t.user_attrs and "modeset_json" in t.user_attrs]
    assert printed == [3, 3] and sum(printed) == len(evaluated), (printed, len(evaluated))
    for (out, _), own in zip(outs, printed):   # each worker's study total: what it saw when it ended,
        seen = int(re.search(r"the study holds (\d+) trials", out).group(1))   # its own trials at least
        assert own <= seen <= len(trials), (own, seen, len(trials))
