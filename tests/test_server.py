"""`modesel serve` (issue 12, fast start): a served `modesel simulate` writes
what the command writes by itself, errors stay one line with exit code 2,
the client's signals reach the command it runs, no process outlives the
command or the server, and another modesel (other sources or NUMBA_*
settings) is refused and runs by itself."""
import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DECAY = ROOT / "studies/data/openfast_free_decay/tower_fa_ss_shaft/Spar_ED_ForED.dat"


def _env(**extra):
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]))
    env.update(extra)
    return env


def _children(pid: int) -> list:
    """The live child processes of `pid` (Linux /proc: its `children` file,
    or, on kernels without it, every process's parent in /proc/*/stat)."""
    try:
        return [int(p) for p in Path(f"/proc/{pid}/task/{pid}/children").read_text().split()]
    except OSError:
        pass
    found = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except (OSError, IndexError):
            continue
        if int(fields[1]) == pid and fields[0] != "Z":
            found.append(int(stat.parent.name))
    return found


def _wait_for(predicate, timeout=20.0):
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if predicate():
            return True
        time.sleep(0.05)
    return False


@pytest.fixture
def server():
    """A server on a fresh socket, warmed on the free decay; its log in a file."""
    folder = Path(tempfile.mkdtemp(prefix="ms-"))       # short: a socket path is at most 108 bytes
    sock, log = folder / "s.sock", folder / "log"
    with open(log, "w") as out:
        proc = subprocess.Popen([sys.executable, "-m", "modesel", "serve", "--socket", str(sock),
                                 "--warm", str(DECAY)], stdout=out, stderr=subprocess.STDOUT, env=_env(),
                                start_new_session=True)
    try:
        assert _wait_for(lambda: "listening on" in log.read_text(), timeout=600), log.read_text()
        yield proc, sock, log
    finally:
        if proc.poll() is None:
            proc.terminate()
            proc.wait(timeout=30)
        for path in (sock, log):
            if path.exists():
                path.unlink()
        folder.rmdir()


def _simulate(sock, out, *extra, tmax="2", **env):
    return [sys.executable, "-m", "modesel", "simulate", str(DECAY), "--tmax", tmax, "--out", str(out), *extra], \
        _env(MODESEL_SERVER=str(sock), **env)


def test_served_simulate_is_the_command_run_by_itself(server, tmp_path):
    proc, sock, log = server
    command, env = _simulate(sock, tmp_path / "served.csv")
    served = subprocess.run(command, capture_output=True, text=True, env=env, cwd=tmp_path)
    assert served.returncode == 0, served.stderr
    assert _wait_for(lambda: "served.csv: exit 0" in log.read_text()), log.read_text()   # the server ran it
    command, env = _simulate("off", tmp_path / "local.csv")
    local = subprocess.run(command, capture_output=True, text=True, env=env, cwd=tmp_path)
    assert local.returncode == 0, local.stderr
    assert (tmp_path / "served.csv").read_bytes() == (tmp_path / "local.csv").read_bytes()
    first = [line.split(" in ")[0] for line in served.stdout.splitlines()]
    assert first == [line.split(" in ")[0] for line in local.stdout.replace("local.csv", "served.csv").splitlines()]
    # a relative path is read from the client's folder; an error is one line, exit code 2
    bad = subprocess.run([sys.executable, "-m", "modesel", "simulate", "nope.fst", "--out", "x.csv"],
                         capture_output=True, text=True, env=env | {"MODESEL_SERVER": str(sock)}, cwd=tmp_path)
    assert bad.returncode == 2 and bad.stderr.strip() == "modesel: error: nope.fst: scene file not found"
    assert _wait_for(lambda: "nope.fst --out x.csv: exit 2" in log.read_text()), log.read_text()
    # linearize is served too
    lin = subprocess.run([sys.executable, "-m", "modesel", "linearize", str(DECAY), "--json"],
                         capture_output=True, text=True, env=env | {"MODESEL_SERVER": str(sock)})
    assert lin.returncode == 0 and lin.stdout.lstrip().startswith(("{", "[")), lin.stderr
    assert _wait_for(lambda: "linearize " in log.read_text() and "--json: exit 0" in log.read_text())


def test_a_served_command_reads_the_aerodyn_deck_as_it_now_is(server, tmp_path):
    """After the server has run an OpenFAST case with AeroDyn (and kept its
    deck), an edit of the AeroDyn file reaches the next served command: it
    writes what the command writes by itself, byte for byte (the deck was
    kept by path alone: the served run kept TipLoss on after it was switched off)."""
    import shutil
    proc, sock, log = server
    for folder in ("steady_08", "common"):
        shutil.copytree(ROOT / "studies/data/openfast" / folder, tmp_path / folder,
                        ignore=shutil.ignore_patterns("*.outb"))
    case = tmp_path / "steady_08" / "steady_08.fst"

    def run(out, where):
        done = subprocess.run([sys.executable, "-m", "modesel", "simulate", str(case), "--tmax", "0.5",
                               "--out", str(tmp_path / out)], capture_output=True, text=True,
                              env=_env(MODESEL_SERVER=where))
        assert done.returncode == 0, done.stderr
        return (tmp_path / out).read_bytes()

    run("first.csv", str(sock))       # then the server warms this case up (numba's cache filled by now)
    assert _wait_for(lambda: "first.csv: exit 0" in log.read_text()), log.read_text()
    before = run("before.csv", str(sock))             # a child of the server that warmed this case up
    deck = tmp_path / "common" / "NREL5MW_AD_v5.dat"
    deck.write_text(deck.read_text().replace("True          TipLoss", "False         TipLoss"))
    served = run("served.csv", str(sock))
    assert _wait_for(lambda: "served.csv: exit 0" in log.read_text()), log.read_text()
    assert served == run("alone.csv", "off") != before


def test_another_modesel_is_refused_and_runs_by_itself(server, tmp_path):
    proc, sock, log = server
    command, env = _simulate(sock, tmp_path / "a.csv", NUMBA_MODESEL_TEST="1")
    done = subprocess.run(command, capture_output=True, text=True, env=env)
    assert done.returncode == 0 and (tmp_path / "a.csv").is_file(), done.stderr
    assert "refused (another modesel" in log.read_text()


def test_client_signals_reach_the_command_and_no_process_outlives_it(server, tmp_path):
    proc, sock, log = server
    for signum, code in ((signal.SIGTERM, 143), (signal.SIGINT, 130), (signal.SIGKILL, -signal.SIGKILL)):
        command, env = _simulate(sock, tmp_path / "long.csv", "--dt", "1", tmax="1e4")
        client = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
        assert _wait_for(lambda: len(_children(proc.pid)) == 1), log.read_text()
        child = _children(proc.pid)[0]
        time.sleep(0.5)
        client.send_signal(signum)
        out, err = client.communicate(timeout=30)
        assert client.returncode == code, err
        if signum != signal.SIGKILL:
            assert err.strip().endswith(f"interrupted ({signal.Signals(signum).name})")
        # SIGKILL: the client's socket closes and the command stops itself
        assert _wait_for(lambda: not Path(f"/proc/{child}").exists(), timeout=10)
    assert not (tmp_path / "long.csv").exists()
    assert proc.poll() is None                    # the server goes on


def test_server_stops_its_commands_and_removes_its_socket(server, tmp_path):
    proc, sock, log = server
    again = subprocess.run([sys.executable, "-m", "modesel", "serve", "--socket", str(sock)],
                           capture_output=True, text=True, env=_env())
    assert again.returncode == 2 and again.stderr.strip().endswith("a server already listens on this socket "
                                                                   "(stop it first)")
    command, env = _simulate(sock, tmp_path / "long.csv", "--dt", "1", tmax="1e4")
    client = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    assert _wait_for(lambda: len(_children(proc.pid)) == 1), log.read_text()
    child = _children(proc.pid)[0]
    proc.send_signal(signal.SIGTERM)
    assert proc.wait(timeout=30) == 143
    assert client.wait(timeout=30) == 143, client.stderr.read() + log.read_text()
    assert not Path(f"/proc/{child}").exists() and not sock.exists()
    # without a server the command runs by itself
    command, env = _simulate(sock, tmp_path / "alone.csv")
    assert subprocess.run(command, capture_output=True, env=env).returncode == 0
    assert (tmp_path / "alone.csv").is_file()


def test_stale_socket_is_replaced_and_bad_options_are_one_line(tmp_path):
    folder = Path(tempfile.mkdtemp(prefix="ms-"))
    sock = folder / "s.sock"
    import socket
    left = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    left.bind(str(sock))                     # a socket file nobody listens on (a killed server's)
    left.close()
    proc = subprocess.Popen([sys.executable, "-m", "modesel", "serve", "--socket", str(sock), "--idle-exit", "0.5"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=_env())
    out, err = proc.communicate(timeout=120)
    assert proc.returncode == 0, err
    assert "listening on" in out and "no request for 0.5 s; stopped" in out and not sock.exists()
    folder.rmdir()
    for args, field in ((["--idle-exit", "nan"], "--idle-exit"), (["--warm", str(tmp_path / "no.fst")], "--warm"),
                        (["--socket", "/" + "x" * 120], "--socket")):
        done = subprocess.run([sys.executable, "-m", "modesel", "serve", *args], capture_output=True, text=True,
                              env=_env())
        assert done.returncode == 2 and len(done.stderr.strip().splitlines()) == 1 and field in done.stderr, \
            done.stderr
