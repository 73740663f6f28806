"""Checked outputs: a new file's permission bits follow the process's umask as it is now, and
reading the umask leaves it as it was."""

import os
import threading

from gshade.io.outputs import new_file_mode


def test_new_files_follow_the_umask_of_the_moment_and_reading_it_changes_nothing():
    before = os.umask(0o022)
    try:
        assert new_file_mode() == 0o644
        os.umask(0o077)
        assert new_file_mode() == 0o600
        assert os.umask(0o077) == 0o077  # still the program's own
        seen = []
        threads = [threading.Thread(target=lambda: seen.append(new_file_mode())) for _ in range(8)]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
        assert seen == [0o600] * 8 and os.umask(0o077) == 0o077
    finally:
        os.umask(before)
