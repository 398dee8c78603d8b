"""Generated drives for the rostests: tescalib_simulate's output for given arguments, written once
per build of the generator and reused by later tests (the same seed gives the same bytes).

The drives live in the devel space's test_drives/ folder (make clean removes them), under a key
made of the arguments and of the generator's binary and libraries: a rebuilt generator writes
its drives anew."""
import glob
import hashlib
import os
import shutil
import subprocess
import tempfile


def _devel_prefix():
    for prefix in os.environ.get('CMAKE_PREFIX_PATH', '').split(os.pathsep):
        if prefix and os.path.isfile(os.path.join(prefix, 'lib', 'tescalib', 'tescalib_simulate')):
            return prefix
    raise RuntimeError('tescalib_simulate not found on CMAKE_PREFIX_PATH (source devel/setup.bash)')


def _key(prefix, args):
    h = hashlib.sha256(' '.join(args).encode())
    files = [os.path.join(prefix, 'lib', 'tescalib', 'tescalib_simulate')]
    files += sorted(glob.glob(os.path.join(prefix, 'lib', 'libtescalib*.so')))
    for path in files:
        with open(path, 'rb') as f:
            h.update(f.read())
    return h.hexdigest()[:16]


def generated_drive(args):
    """The folder of `tescalib_simulate ARGS --out DIR` (ARGS without --out), written if needed."""
    prefix = _devel_prefix()
    root = os.path.join(prefix, 'test_drives')
    drive = os.path.join(root, _key(prefix, args))
    if os.path.isfile(os.path.join(drive, 'sim_info.txt')):
        return drive
    os.makedirs(root, exist_ok=True)
    work = tempfile.mkdtemp(prefix='writing_', dir=root)
    try:
        subprocess.run(['rosrun', 'tescalib', 'tescalib_simulate'] + args +
                       ['--out', os.path.join(work, 'drive')], check=True,
                       stdout=subprocess.DEVNULL)
        os.rename(os.path.join(work, 'drive'), drive)
    except OSError:
        if not os.path.isfile(os.path.join(drive, 'sim_info.txt')):  # not written by another
            raise
    finally:
        shutil.rmtree(work, ignore_errors=True)
    return drive
