"""The journals read again between an adaptive map's rounds (``journal.HistoryReader``): each
read parses what was appended since the last and gives what a reading of the whole folder gives
(the entries the writers wrote, lines dropped, unfinished starts, stalls), whatever happened to
the files in between: appended, torn, completed, replaced, deleted, new."""

from __future__ import annotations

import os

from hpcontact.sweep.data import journal
from hpcontact.sweep.data.journal import ERROR, OK, Entry, HistoryReader, Journal, read_history


def entry(key: str, status: int = OK, finished: float = 1.0, value: float = 1.0) -> Entry:
    return Entry(
        key=key,
        params={"nu": 0.3},
        status=status,
        message="" if status == OK else "boom",
        record={"K_xx": value},
        wall_time_s=0.5,
        finished=finished,
        rank=0,
    )


def count_parsed(monkeypatch) -> list[int]:
    """``journal.scan_lines`` patched to record the bytes of each piece it parses; that list."""
    parsed: list[int] = []
    scan = journal.scan_lines

    def counted(data: bytes):
        parsed.append(len(data))
        return scan(data)

    monkeypatch.setattr(journal, "scan_lines", counted)
    return parsed


def test_each_read_gives_the_whole_folder_and_parses_only_what_is_new(tmp_path, monkeypatch):
    reader = HistoryReader(tmp_path)
    assert reader.read() == read_history(tmp_path) and reader.read().files == 0
    a = Journal(tmp_path / "rank00000-a.jsonl", 0, {"session": "a"})
    a.started("k1")
    a.append(entry("k1", value=1.0))
    a.started("k2")  # still running
    a.sync()
    first = reader.read()
    assert set(first.entries) == {"k1"} and set(first.unfinished) == {"k2"} and first.headers[0]["session"] == "a"
    assert first == read_history(tmp_path)

    # appended: a later outcome of k1, k2 finished, half a line torn at the end of the file
    a.append(entry("k1", finished=2.0, value=2.0))
    a.append(entry("k2", status=ERROR))
    a.write_raw(Journal.line(entry("k3"))[:20])
    a.sync()
    parsed = count_parsed(monkeypatch)
    second = reader.read()
    assert parsed and sum(parsed) < os.path.getsize(tmp_path / "rank00000-a.jsonl") / 2  # the new lines alone
    monkeypatch.undo()
    assert second.entries["k1"].record == {"K_xx": 2.0} and second.entries["k2"].status == ERROR
    assert second.unfinished == {} and second.dropped == 1  # the torn tail
    assert second == read_history(tmp_path)

    # the torn line is followed by a whole one (it is dropped with it), a new file, a stall
    a.append(entry("k4"))
    a.close()
    b = Journal(tmp_path / "rank00001-b.jsonl", 1, {"session": "b"})
    b.append(entry("k5"))
    b.stalled(0)
    b.close()
    third = reader.read()
    assert set(third.entries) == {"k1", "k2", "k5"} and third.dropped == 1 and third.stalled == {("b", 0)}
    assert third.entries["k1"] is second.entries["k1"]  # read once: the same object
    assert third == read_history(tmp_path)

    # a file replaced by a shorter one (another writer's), another deleted
    (tmp_path / "rank00001-b.jsonl").unlink()
    replaced = tmp_path / "rank00000-a.jsonl"
    replaced.unlink()
    with Journal(replaced, 0, {"session": "c"}) as c:
        c.append(entry("k6"))
    fourth = reader.read()
    assert set(fourth.entries) == {"k6"} and fourth.dropped == 0 and fourth.stalled == set()
    assert fourth.headers[0]["session"] == "c" and fourth == read_history(tmp_path)


def test_advances_while_the_ranks_write_leave_the_read_the_same_and_only_the_rest_to_parse(tmp_path, monkeypatch):
    """Rank 0 parses the journals during a round (``advance``) while ranks write them: a line
    half written at an advance (a rank writing it) is read whole later, not dropped; a file whose
    header is half written likewise; the read after the round equals a reading of the whole
    folder and parses only what came after the last advance."""
    reader = HistoryReader(tmp_path)
    a = Journal(tmp_path / "rank00000-a.jsonl", 0, {"session": "a"})
    a.started("k1")
    reader.advance()  # the header and a start
    line = Journal.line(entry("k1", value=3.0))
    a.write_raw(line[:25])
    reader.advance()  # half the line: left for later
    a.write_raw(line[25:])
    b_path = tmp_path / "rank00001-a.jsonl"
    b = Journal(b_path, 1, {"session": "a"})
    b.started("k2")
    header_and_start = b_path.read_bytes()
    b_path.write_bytes(header_and_start[:10])  # the header as a rank writes it: partly there
    reader.advance()
    b_path.write_bytes(header_and_start)
    reader.advance()
    b.append(entry("k2", status=ERROR))
    b.close()
    a.append(entry("k3"))
    a.close()
    parsed = count_parsed(monkeypatch)
    history = reader.read()
    monkeypatch.undo()
    tail = len(Journal.line(entry("k3"))) + len(Journal.line(entry("k2", status=ERROR)))
    assert sum(parsed) == tail  # the two lines written after the last advance, nothing else
    whole = read_history(tmp_path)
    assert history == whole and history.dropped == 0 and history.unfinished == {}
    assert set(history.entries) == {"k1", "k2", "k3"} and history.entries["k1"].record == {"K_xx": 3.0}
    assert [h["rank"] for h in history.headers] == [0, 1]
