"""Output paths are checked before any work, and the checks leave nothing behind."""

from __future__ import annotations

import threading
from pathlib import Path

import pytest

from flightdata.outputs import OutputError, check_file_output, check_folder_output


def test_a_file_in_an_existing_folder_passes_and_is_not_created(tmp_path: Path) -> None:
    assert check_file_output("--json", tmp_path / "a.json") == tmp_path / "a.json"
    assert list(tmp_path.iterdir()) == []


def test_a_file_in_a_missing_folder_passes_and_the_folder_is_removed_again(
        tmp_path: Path) -> None:
    check_file_output("--rrd", tmp_path / "out" / "deeper" / "f.rrd")
    assert list(tmp_path.iterdir()) == []


def test_an_existing_file_is_not_changed_by_the_check(tmp_path: Path) -> None:
    path = tmp_path / "a.json"
    path.write_text("kept")
    check_file_output("--json", path)
    assert path.read_text() == "kept"


@pytest.mark.parametrize(("path", "words"), [
    ("/proc", "--timing-log /proc: is a folder, not a file"),
    ("/proc/nope.csv", "--timing-log /proc/nope.csv: cannot write: "),
    ("/proc/nope/t.csv", "--timing-log /proc/nope/t.csv: cannot write: "),
])
def test_unwritable_files_are_one_line(path: str, words: str) -> None:
    with pytest.raises(OutputError) as info:
        check_file_output("--timing-log", path)
    assert str(info.value).startswith(words)
    assert "\n" not in str(info.value)


def test_a_missing_folder_is_probed_and_removed_again(tmp_path: Path) -> None:
    check_folder_output("--figures", tmp_path / "a" / "b" / "c")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("path", ["/proc/nope", "/proc/nope/deeper"])
def test_a_folder_that_cannot_be_created_is_one_line(path: str) -> None:
    with pytest.raises(OutputError) as info:
        check_folder_output("--figures", path)
    assert str(info.value).startswith(f"--figures {path}: cannot write there: ")


def test_a_file_where_a_folder_is_wanted_is_refused(tmp_path: Path) -> None:
    (tmp_path / "f").write_text("")
    with pytest.raises(OutputError, match="is a file, not a folder"):
        check_folder_output("--report", tmp_path / "f")


def test_two_checks_of_the_same_missing_folder_at_once_both_pass(tmp_path: Path) -> None:
    """Two ground stations started together with the same ``--out-dir``: the check creates
    nothing under the folder's name, so neither can find it half made by the other."""
    errors: list[BaseException] = []

    def check() -> None:
        try:
            for _ in range(200):
                check_folder_output("--out-dir", tmp_path / "out")
                check_file_output("--tlog", tmp_path / "out" / "f.tlog")
        except OutputError as err:
            errors.append(err)

    threads = [threading.Thread(target=check) for _ in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(timeout=60.0)
    assert errors == []
    assert list(tmp_path.iterdir()) == []
