"""Learning as a library function (:mod:`hila_lang.hierarchy.learn`) and the one demonstration-file
writer beside its reader (:mod:`hila_lang.osila.demofile`): the command, the studio and the letters
world learn through them, so each makes the file ``hila learn`` makes."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from hila_lang.cli import main
from hila_lang.core.errors import InputError
from hila_lang.hierarchy.learn import default_tags, learn, learn_files
from hila_lang.osila.demofile import demo_csv, load_icps, read_demo_csv, write_demo_csv, write_icps
from hila_lang.osila.template import load_template, save_template

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "tests" / "data" / "core"


@pytest.mark.parametrize("dim, timed", [(2, False), (2, True), (3, False), (3, True)])
def test_the_writer_round_trips_through_the_reader_exactly(tmp_path, dim, timed):
    rng = np.random.default_rng(dim + 10 * timed)
    path = rng.normal(scale=0.3, size=(40, dim)) / 7.0  # floats with long decimal expansions
    times = np.cumsum(rng.uniform(0.01, 0.1, 40)) if timed else None
    write_demo_csv(tmp_path / "d.csv", path, times)
    back, back_times = read_demo_csv(tmp_path / "d.csv")
    assert np.array_equal(back, path)  # repr round-trips: bit for bit
    assert (back_times is None) if not timed else np.array_equal(back_times, times)
    assert (tmp_path / "d.csv").read_text().splitlines()[0] == ("t," if timed else "") + ",".join("xyz"[:dim])
    icps = {"a": path[0], "b": path[-1]}
    write_icps(tmp_path / "i.yaml", icps)
    assert {k: list(v) for k, v in icps.items()} == load_icps(tmp_path / "i.yaml", dim)


def test_the_writer_fixes_digits_when_asked_and_refuses_a_ragged_path():
    text = demo_csv([[0.123456789, 1.0, 2.5]], [1 / 3], decimals=3, time_decimals=2)
    assert text == "t,x,y,z\n0.33,0.123,1.000,2.500\n"
    with pytest.raises(InputError, match="expected a path"):
        demo_csv(np.zeros((4, 4)))
    with pytest.raises(InputError, match="T times"):
        demo_csv(np.zeros((4, 2)), np.zeros(3))


def test_default_tags_are_the_commands():
    assert default_tags([], None) == (1, [])
    assert default_tags(["a", "b"], None) == (2, ["a", "b"])
    assert default_tags([], 3) == (3, ["s1", "s2", "s3"])
    with pytest.raises(InputError, match="expected -k >= 1, got 0"):
        default_tags([], 0)


def test_learn_files_is_the_file_hila_learn_writes(tmp_path):
    argv = ["-k", "3", "--tags", "reach,draw,retract", "--contact", "draw", "--method", "kmeans", "--seed", "2"]
    assert main(["learn", str(DATA / "demo.csv"), "--icps", str(DATA / "icps.yaml"), *argv,
                 "--name", "c", "-o", str(tmp_path / "cli.yaml")]) == 0
    t = learn_files(str(DATA / "demo.csv"), str(DATA / "icps.yaml"), name="c", tags=["reach", "draw", "retract"],
                    contact=["draw"], k=3, method="kmeans", seed=2)
    save_template(t, tmp_path / "lib.yaml")
    assert (tmp_path / "lib.yaml").read_text() == (tmp_path / "cli.yaml").read_text()
    assert "learned from" in t.description and "by k-means (k = 3)" in t.description
    # the numbers in memory learn the same template as the files they were written to
    path, times = read_demo_csv(DATA / "demo.csv")
    mem = learn("c", path, load_icps(DATA / "icps.yaml", 3), times=times, tags=["reach", "draw", "retract"],
                contact=["draw"], method="kmeans", seed=2, description=t.description)
    assert [(s.tag, s.start, s.stop, s.contact) for s in mem.segments] == \
        [(s.tag, s.start, s.stop, s.contact) for s in t.segments]


def test_learn_names_the_file_of_a_bad_path_and_refuses_contact_without_segments(tmp_path):
    demo = tmp_path / "d.csv"
    demo.write_text("t,x,y\n0,0,0\n1,1,1\n")
    write_icps(tmp_path / "i.yaml", {"a": [0, 0]})
    with pytest.raises(InputError, match="--contact needs segments"):
        learn_files(demo, tmp_path / "i.yaml", name="d", contact=["x"])
    with pytest.raises(InputError, match="'icps.a' as 2 numbers") as info:
        learn("d", [[0, 0], [1, 1]], {"a": [0, 0, 0]}, source="d.csv")
    assert info.value.file == "d.csv"


def test_the_letters_world_learns_its_shipped_letter_again(tmp_path, capsys):
    """The letters' handwriting model writes the demonstration through the one writer and learns it
    in process: the shipped CSV byte for byte, the shipped template but for where it was made."""
    from hila_lang.worlds.letters.handwriting import main as handwriting

    assert handwriting(["--out", str(tmp_path), "--letters", "H"]) == 0
    shipped = ROOT / "primitives" / "letters"
    assert (tmp_path / "demos" / "H.csv").read_bytes() == (shipped / "demos" / "H.csv").read_bytes()
    assert (tmp_path / "demos" / "box.yaml").read_bytes() == (shipped / "demos" / "box.yaml").read_bytes()
    new, old = load_template(tmp_path / "H.yaml"), load_template(shipped / "H.yaml")
    assert np.array_equal(new.path, old.path) and np.array_equal(new.times, old.times)
    assert new.segments == old.segments and {k: list(v) for k, v in new.icps.items()} == \
        {k: list(v) for k, v in old.icps.items()}
    assert new.description.replace(str(tmp_path), "primitives/letters") == " ".join(old.description.split())
