"""Files never block other threads: every open, read and write of the
binding runs without the GIL, and a named pipe with nobody at its other
end is refused (an output) or read as empty (an input) at once, never
waited for. Each case runs in a child interpreter under a timeout, so a
call that hangs fails the test instead of hanging the suite."""

import json
import os
import subprocess
import sys

import pytest

# The child's whole run: a few calls of well under a second each; far
# more than that on a loaded machine, far less than a hang.
CHILD_TIMEOUT_S = 120
# The longest another Python thread may go without running while a call
# waits on a pipe (as test_citizen's MAX_PAUSE_S: a thread that gets the
# GIL runs every few milliseconds).
MAX_PAUSE_S = 0.25
# How long the other end of a pipe keeps the call waiting before it reads
# or writes: long against MAX_PAUSE_S, so a call holding the GIL shows.
OTHER_END_DELAY_S = 1.0

CHILD = r"""
import json, os, sys, threading, time
import numpy as np
import ssskit

d, delay = sys.argv[1], float(sys.argv[2])
out = {}
stamps = []
stop = threading.Event()

def spin():
    while not stop.is_set():
        stamps.append(time.perf_counter())
        time.sleep(0.001)

def longest_pause(call):
    t0 = time.perf_counter()
    try:
        call()
        err = None
    except Exception as e:
        err = f"{type(e).__name__}: {e}"
    t1 = time.perf_counter()
    inside = [s for s in list(stamps) if t0 <= s <= t1]
    gaps = np.diff([t0, *inside, t1])
    return [err, float(gaps.max()), t1 - t0, t1]

spinner = threading.Thread(target=spin, daemon=True)
spinner.start()
profile = ssskit.profile("skin1", "pbd")
kernel = ssskit.fit(profile, "preintegrate")
img = np.ones((8, 8, 3), np.float32)

# Outputs to pipes nobody reads: refused at once.
for name, call in [("image.exr", lambda f: ssskit.write_image(f, img)),
                   ("kernel.json", kernel.save), ("profile.json", profile.save)]:
    f = os.path.join(d, name)
    os.mkfifo(f)
    out[name] = longest_pause(lambda: call(f))

# An output to a pipe read slowly: the write waits for the reader, a Python
# thread, which runs only if the write released the GIL.
slow = os.path.join(d, "slow.exr")
os.mkfifo(slow)
reader_fd = os.open(slow, os.O_RDONLY | os.O_NONBLOCK)
got = bytearray()
other_end = {}
def drain():
    time.sleep(delay)
    other_end["slow.exr"] = time.perf_counter()
    while True:
        try:
            chunk = os.read(reader_fd, 1 << 16)
        except BlockingIOError:
            time.sleep(0.001)
            continue
        if not chunk and got:
            return
        got.extend(chunk)
r = threading.Thread(target=drain)
r.start()
big = np.random.default_rng(1).random((256, 256, 3)).astype(np.float32)
out["slow.exr"] = longest_pause(lambda: ssskit.write_image(slow, big))
r.join()
out["slow.exr bytes"] = [len(got), bytes(got[:4]).hex()]
out["slow.exr"].append(other_end["slow.exr"])

# An input from a pipe whose writer is slow: the read waits for it, a
# Python thread, which runs only if the read released the GIL.
pipe = os.path.join(d, "in.json")
os.mkfifo(pipe)
writer_fd = os.open(pipe, os.O_RDWR)
def write_late():
    time.sleep(delay)
    other_end["in.json"] = time.perf_counter()
    os.write(writer_fd, b'{"schema": "ssskit.other/1"}')
    os.close(writer_fd)
w = threading.Thread(target=write_late)
w.start()
out["in.json"] = longest_pause(lambda: ssskit.load(pipe))
w.join()
out["in.json"].append(other_end["in.json"])

# An input pipe with no writer at all: read as empty, not waited for.
empty = os.path.join(d, "empty.exr")
os.mkfifo(empty)
out["empty.exr"] = longest_pause(lambda: ssskit.read_image(empty))
stop.set()
print(json.dumps(out))
"""


@pytest.fixture(scope="module")
def child(tmp_path_factory):
    d = tmp_path_factory.mktemp("pipes")
    done = subprocess.run(
        [sys.executable, "-c", CHILD, str(d), str(OTHER_END_DELAY_S)],
        capture_output=True, text=True, timeout=CHILD_TIMEOUT_S,
    )
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout.splitlines()[-1])


@pytest.mark.parametrize("name", ["image.exr", "kernel.json", "profile.json"])
def test_an_output_pipe_without_a_reader_is_refused_at_once(child, name):
    err, pause, took, _ = child[name]
    assert err is not None and err.startswith("OSError") and "no program reads" in err and name in err
    assert took < OTHER_END_DELAY_S and pause < MAX_PAUSE_S


def test_a_slow_reader_keeps_the_write_waiting_not_the_interpreter(child):
    err, pause, _, ended, read_from = child["slow.exr"]
    assert err is None
    # The write waited for the reader thread, and other threads ran meanwhile.
    assert ended >= read_from and pause < MAX_PAUSE_S
    size, magic = child["slow.exr bytes"]
    assert size > 256 * 256 * 3 * 4 and magic == "762f3101"  # OpenEXR's magic number


def test_a_slow_writer_keeps_the_read_waiting_not_the_interpreter(child):
    err, pause, _, ended, written_at = child["in.json"]
    assert err is not None and "schema 'ssskit.other/1' is not one ssskit.load reads" in err
    # The read waited for the writer thread, and other threads ran meanwhile.
    assert ended >= written_at and pause < MAX_PAUSE_S


def test_an_input_image_pipe_is_refused_by_what_it_is(child):
    # An image is read twice (headers, then pixels), so a pipe is refused as
    # a pipe, at once, with the file named (the CLI's message).
    err, pause, took, _ = child["empty.exr"]
    assert err is not None and err.startswith("OSError") and "empty.exr" in err
    assert "is a pipe" in err
    assert took < OTHER_END_DELAY_S
