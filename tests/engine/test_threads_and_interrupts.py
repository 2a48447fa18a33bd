"""The dedicated thread pool, its environment variable, and Ctrl-C."""

import os
import signal
import subprocess
import sys
import textwrap

import edmf_rs


def run_python(code: str, env: dict | None = None, timeout: float = 120, **kw) -> subprocess.CompletedProcess:
    full_env = {**os.environ, **(env or {})}
    return subprocess.run([sys.executable, "-c", textwrap.dedent(code)], env=full_env,
                          capture_output=True, text=True, timeout=timeout, **kw)


def test_set_num_threads_round_trips():
    edmf_rs.set_num_threads(1)
    assert edmf_rs.get_num_threads() == 1
    edmf_rs.set_num_threads(2)
    assert edmf_rs.get_num_threads() == 2


def test_a_forked_child_gets_a_pool_of_its_own():
    # A child inherits the parent's pool but not its threads: it must build its
    # own, whether it asks for the same size or not at all (no hang).
    out = run_python("""
        import os, signal, numpy as np, edmf_rs
        t = edmf_rs.Thresholds([-1.0], [1.0])
        edmf_rs.set_num_threads(2)
        edmf_rs.falsify(np.zeros((10, 1)), [0.0], t)  # the parent's pool is running
        for same_size in (True, False):
            pid = os.fork()
            if pid == 0:
                signal.alarm(30)  # a hung child dies instead of outliving the test
                if same_size:
                    edmf_rs.set_num_threads(2)
                r = edmf_rs.falsify(np.zeros((100_000, 1)), [0.0], t, progress=False)
                os._exit(0 if r.n_candidates == 100_000 else 3)
            _, status = os.waitpid(pid, 0)
            print(os.waitstatus_to_exitcode(status))
    """, timeout=60)
    assert out.stdout.split() == ["0", "0"], out.stderr


def test_environment_variable_sets_the_pool():
    out = run_python("import edmf_rs; print(edmf_rs.get_num_threads())", env={"EDMF_RS_NUM_THREADS": "3"})
    assert out.stdout.strip() == "3", out.stderr
    bad = run_python("import edmf_rs; edmf_rs.get_num_threads()", env={"EDMF_RS_NUM_THREADS": "many"})
    assert bad.returncode != 0 and "EDMF_RS_NUM_THREADS: expected an integer from 1 to" in bad.stderr


def test_ctrl_c_interrupts_a_long_falsification():
    # One huge call into Rust (zero pages: no real memory), interrupted mid-way.
    code = """
        import sys, numpy as np, edmf_rs
        p = np.zeros((150_000_000, 20), dtype=np.float32)
        t = edmf_rs.Thresholds(np.ones(20), np.ones(20) * 2)
        print("started", flush=True)
        try:
            for _ in range(100):
                edmf_rs.falsify(p, np.zeros(20), t, diagnostics=False)
        except KeyboardInterrupt:
            print("interrupted", flush=True)
            sys.exit(3)
        print("finished", flush=True)
    """
    proc = subprocess.Popen([sys.executable, "-c", textwrap.dedent(code)], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    assert proc.stdout.readline().strip() == "started"
    import time

    time.sleep(1.0)
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=60)  # a hang fails here
    assert proc.returncode == 3, (out, err)
    assert "interrupted" in out


def test_running_out_of_memory_is_a_memory_error_not_an_abort():
    # Address space capped just above what is mapped: the violation counts of
    # 100M instances (400 MB) cannot be kept (the candidates would: a bitmap of
    # 12.5 MB). Rust must report it, not abort the interpreter.
    code = """
        import resource, numpy as np, edmf_rs
        edmf_rs.set_num_threads(1)
        p = np.zeros((100_000_000, 1), dtype=np.float32)
        t = edmf_rs.Thresholds([-1.0], [1.0])
        edmf_rs.falsify(p[:10], [0.0], t)  # warm up: pool and code mapped
        used = int(open("/proc/self/statm").read().split()[0]) * resource.getpagesize()
        resource.setrlimit(resource.RLIMIT_AS, (used + 300 * 2**20, resource.RLIM_INFINITY))
        try:
            edmf_rs.falsify(p, [0.0], t, keep_violations=True)
        except MemoryError as exc:
            print("MemoryError:", exc)
    """
    out = run_python(code)
    assert out.returncode == 0, out.stderr[-2000:]
    assert "MemoryError: out of memory keeping" in out.stdout
