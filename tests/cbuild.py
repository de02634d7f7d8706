"""The C core's tick files (haptex.export.TICK_FILES, every source but the simulator's loops)
compiled once per flag set in a test process: the exported ticks of test_export.py and the
core's sanitizer fuzz of test_core.py link the same objects. The tests that use them share the
xdist group GROUP, so that under ``--dist loadgroup`` one worker builds each set once."""

import functools
import shutil
import subprocess

from haptex import core
from haptex.export import TICK_FILES

CC = shutil.which("cc") or shutil.which("gcc")
STRICT = ("-std=c99", "-Wall", "-Wextra", "-pedantic", "-Werror")
# AddressSanitizer and UndefinedBehaviorSanitizer, any report fatal; without -g (the objects
# build in a third less time, and a report still names the function: add -g by hand for lines)
SANITIZE = ("-O1", "-fsanitize=address,undefined", "-fno-sanitize-recover=all", "-fno-omit-frame-pointer")
GROUP = "c-core-objects"


@functools.lru_cache(maxsize=None)
def core_objects(tmp_root, flags: tuple, cc: str | None = None) -> tuple:
    """The core's tick files compiled with ``flags`` (by ``cc``, default the host's) into
    ``tmp_root``, once per compiler and flag set in this process, two at a time (every export
    copies them unchanged, which test_the_export_is_the_core checks): the objects' paths."""
    from concurrent.futures import ThreadPoolExecutor

    cc = cc or CC
    tag = abs(hash((cc, flags)))

    def one(name):
        obj = tmp_root / f"{name[:-2]}{tag}.o"
        r = subprocess.run([cc, *flags, "-c", "-o", str(obj), str(core.SOURCE_DIR / name)], capture_output=True,
                           text=True)
        assert r.returncode == 0, f"{cc} {' '.join(flags)} {name}:\n{r.stderr}"
        return str(obj)

    with ThreadPoolExecutor(2) as pool:
        return tuple(pool.map(one, [n for n in TICK_FILES if n.endswith(".c")]))


def sanitizers_work(tmp_path) -> bool:
    """Whether this compiler builds and runs a program under -fsanitize=address,undefined."""
    probe = tmp_path / "probe.c"
    probe.write_text("int main(void) { return 0; }\n")
    r = subprocess.run([CC, "-fsanitize=address,undefined", "-o", str(tmp_path / "probe"), str(probe)],
                       capture_output=True)
    return r.returncode == 0 and subprocess.run([str(tmp_path / "probe")], capture_output=True).returncode == 0
