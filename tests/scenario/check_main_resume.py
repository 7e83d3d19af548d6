"""The README's main scenario killed twice (SIGKILL at 70 s and again 60 s into the resume) and resumed
with --resume, against an uninterrupted run beside it; every output compared as
tests/scenario/test_resume_kill.py compares them; tools.plot_sps on the resumed folder (issue 64's
"done when"). A manual check, not a ctest entry: two main-scenario runs side by side, ~6-10 min.

    /usr/bin/python3 tests/scenario/check_main_resume.py BUILD/sparkdem WORKDIR
"""
import os, signal, subprocess, sys, shutil

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(REPO, "tests", "scenario"))
sys.path.insert(0, REPO)
import test_resume_kill as t  # noqa: E402

BIN = os.path.abspath(sys.argv[1])
SCENE = os.path.join(REPO, "configs", "sps_nial.json")
A, B = os.path.join(sys.argv[2], "A"), os.path.join(sys.argv[2], "B")
for d in (A, B):
    shutil.rmtree(d, ignore_errors=True)
env = dict(os.environ, OMP_NUM_THREADS="1")
pa = subprocess.Popen([BIN, "run", SCENE, "-o", A, "--threads", "1", "--quiet"], env=env, cwd=REPO)
def killed_after(cmd, s):
    p = subprocess.Popen(cmd, env=env, cwd=REPO)
    try:
        return p.wait(timeout=s)
    except subprocess.TimeoutExpired:
        p.send_signal(signal.SIGKILL); p.wait(); return None
print("first run:", killed_after([BIN, "run", SCENE, "-o", B, "--threads", "1", "--quiet"], 70), flush=True)
print("resume 1:", killed_after([BIN, "run", SCENE, "-o", B, "--threads", "1", "--resume"], 60), flush=True)
r = subprocess.run([BIN, "run", SCENE, "-o", B, "--threads", "1", "--resume"], env=env, cwd=REPO)
print("resume 2 exit", r.returncode, flush=True)
print("uninterrupted exit", pa.wait(), flush=True)
t.ROOTS[:] = [A, B]
problems = t.compare_dirs(A, B)
print(len(problems), "differences")
for p in problems[:30]:
    print(" ", p)
print("plot_sps on the resumed folder: exit", t.plot(B, os.path.join(sys.argv[2], "plot_B.log")))
print("files compared:", len(t.files_of(A)))
