"""Bad input, third round (issue 32, section 5), at the root: a stored definition judged
before its folder is made, an interrupted store that kept nothing says so and leaves
nothing, a killed writer's temporaries removed, speed tables judged before they are read,
sizes bounded before they are allocated."""

from __future__ import annotations

import os
import re

import pytest

from analysis.errors import InputError
from analysis.integrate.speed_profile import MAX_ROWS, parse_speed, read_table
from analysis.sweeps.executors import SerialExecutor, make_executor, workers_of
from analysis.sweeps.store import PointStore


def test_a_definition_beyond_int64_is_refused_before_the_folder_is_made(tmp_path):
    with pytest.raises(InputError, match=r"^attractors\.seed: must be a whole number in "
                                         r"\[-9223372036854775807, 9223372036854775807\], "
                                         r"got 1180591620717411303424$"):
        PointStore(tmp_path / "a.nc", {"attractors": {"seed": 2**70}}, lock=True)
    assert list(tmp_path.iterdir()) == []
    store = PointStore(tmp_path / "a.nc", {"attractors": {"seed": 2**63 - 1}}, lock=True)
    store.remove()


def test_an_interrupted_store_that_kept_nothing_says_so_and_leaves_nothing(tmp_path):
    store = PointStore(tmp_path / "c.nc", {"kind": "test"}, lock=True)
    exc = KeyboardInterrupt()
    store.stopped(exc, 40)
    assert exc.__notes__ == ["nothing was kept: none of the 40 points had finished"]
    assert list(tmp_path.iterdir()) == []
    refused = InputError("x: bad")  # a refusal before any point: no note
    PointStore(tmp_path / "c.nc", {"kind": "test"}, lock=True).stopped(refused, 40)
    assert not getattr(refused, "__notes__", None)


def test_an_interrupted_store_that_kept_points_says_how_many(tmp_path):
    store = PointStore(tmp_path / "c.nc", {"kind": "test"}, lock=True)
    store.save("p0", {"v": [1.0]})
    exc = KeyboardInterrupt()
    store.stopped(exc, 40)
    assert exc.__notes__ == [f"1 of 40 points kept in {tmp_path / 'c.nc.parts'}; run the "
                             "same command to resume"]


def test_the_store_removes_temporaries_a_killed_writer_left(tmp_path):
    store = PointStore(tmp_path / "c.nc", {"kind": "test"}, lock=True)
    store.save("p0", {"v": [1.0]})
    (store.folder / ".p1.abcd1234.tmp").write_bytes(b"half a point")
    store.close()
    again = PointStore(tmp_path / "c.nc", {"kind": "test"}, lock=True)
    assert sorted(p.name for p in again.folder.iterdir()) == [
        "command", "lock", "p0.npz", "sweep.json"]
    again.remove()


def test_a_speed_table_with_a_byte_order_mark_is_read(tmp_path):
    path = tmp_path / "t.csv"
    path.write_bytes(b"\xef\xbb\xbft_s,speed_rpm\r\n0,1000\r\n0.5,3000\r\n")
    profile = read_table(path)
    assert profile.rpm == (1000.0, 3000.0) and profile.times == (0.0, 0.5)


@pytest.mark.parametrize(("make", "said"), [
    (lambda p: p.mkdir(), "is a folder"),
    (lambda p: os.mkfifo(p), "is a pipe (FIFO), not a plain file"),
    (lambda p: None, "does not exist"),
    (lambda p: p.symlink_to(p.parent / "gone.csv"), "is a symbolic link to"),
])
def test_a_speed_table_that_is_no_file_is_named_as_what_it_is(tmp_path, make, said):
    path = tmp_path / "t.csv"
    make(path)
    with pytest.raises(InputError, match="^" + re.escape(f"speed_rpm: the speed table "
                                                         f"'{path}' {said}")):
        parse_speed(str(path))


def test_a_device_is_no_speed_table():
    with pytest.raises(InputError, match="'/dev/null' is a device or socket"):
        read_table("/dev/null")


def test_a_speed_table_is_bounded_before_its_rows_are_parsed(tmp_path):
    path = tmp_path / "t.csv"
    path.write_text("t_s,speed_rpm\n" + "".join(f"{i},{1000 + i}\n"
                                                for i in range(MAX_ROWS + 1)))
    with pytest.raises(InputError, match=f"must have 2 to {MAX_ROWS} rows, got more than"):
        read_table(path)
    path.write_text("t_s,speed_rpm\n" + "0,1000\n" * 200_000)  # 1.4 MB, rows never parsed
    with pytest.raises(InputError, match="bytes; at most 1048576 bytes"):
        read_table(path)


def test_workers_of_an_executor():
    assert workers_of(SerialExecutor()) == 1
    assert workers_of(make_executor("processes", 3)) == 3
