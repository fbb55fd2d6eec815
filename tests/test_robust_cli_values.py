"""Command-line values a person (or an unset shell variable) gets wrong: refused with exit 2,
nothing written (issue 32, items 3 and 5), and pictures refused by their header (item 10)."""

from __future__ import annotations

import os
import struct
import zlib
from pathlib import Path

import numpy as np
import pytest

from hila_lang import cli
from hila_lang.core.errors import InputError
from hila_lang.core.images import MAX_PIXELS, decode_image, image_size, read_picture

ROOT = Path(__file__).resolve().parent.parent
GAME = str(ROOT / "programs" / "game.hila")


@pytest.mark.parametrize("argv", [
    ["eval", "--out", ""], ["eval", "--out", "  "], ["exec", GAME, "--out", ""], ["exec", GAME, "--trace", ""],
    ["exec", GAME, "--record", ""], ["compile", GAME, "-o", ""], ["snapshot", "--out", ""],
    ["learn", "x.csv", "--icps", "x.yaml", "-o", ""], ["imitate", "circle", "--task", "t.yaml", "-o", ""],
])
def test_an_empty_output_path_is_refused_and_nothing_is_written(tmp_path, monkeypatch, capsys, argv):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(SystemExit) as info:
        cli.main(argv)
    assert info.value.code == 2
    assert "expected a path, got an empty one" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("argv, message", [
    (["eval", "--seed", "-1"], "argument --seed: expected a whole number >= 0, got -1"),
    (["exec", GAME, "--seed", "-1"], "argument --seed: expected a whole number >= 0, got -1"),
    (["learn", "x.csv", "-o", "y.yaml", "--seed", "-2"], "argument --seed: expected a whole number >= 0, got -2"),
    (["eval", "--seed", "1e999"], "argument --seed: expected a whole number >= 0, got '1e999'"),
    (["eval", "--seed", "9" * 41], "argument --seed: expected a whole number >= 0"),
    (["eval", "--trials-per-setup", "1000000000"], "argument --trials-per-setup: expected a whole number from 1 "
                                                  "to 1000, got 1000000000"),
    (["eval", "--jobs", "0"], "expected --jobs >= 1 or -1 (all cores), got 0"),
    (["eval", "--threshold", "nan"], "argument --threshold: expected a finite number >= 0, got nan"),
    (["eval", "--timing", "inf"], "argument --timing: expected a finite number >= 0, got inf"),
])
def test_numbers_are_checked_alike_in_every_command(capsys, argv, message):
    with pytest.raises(SystemExit) as info:
        cli.main(argv)
    assert info.value.code == 2
    assert message in capsys.readouterr().err


def test_show_names_what_a_path_really_is(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "folder").mkdir()
    os.mkfifo(tmp_path / "pipe")
    os.symlink(tmp_path / "nowhere", tmp_path / "dangling")
    for name, message in (("folder", "expected a template file, got a directory"),
                          ("pipe", "expected a template file (a regular file), got a FIFO"),
                          ("dangling", "template file not found"), ("gone.yaml", "template file not found")):
        assert cli.main(["show", name]) == 2
        err = capsys.readouterr().err
        assert err.startswith(f"{name}: error: {message}"), err


def _png_header(width: int, height: int) -> bytes:
    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0))
            + chunk(b"IDAT", zlib.compress(b"\0" * 4096)) + chunk(b"IEND", b""))


@pytest.mark.parametrize("ext", [".png", ".jpg", ".bmp", ".ppm", ".pgm", ".tif"])
def test_every_accepted_format_tells_its_size_from_the_header(ext):
    import cv2

    image = np.random.default_rng(0).integers(0, 255, (37, 53, 3), np.uint8)
    ok, data = cv2.imencode(ext, image[:, :, 0] if ext == ".pgm" else image)
    assert ok and image_size(data.tobytes()) == (53, 37)
    assert decode_image(data.tobytes()).shape[:2] == (37, 53)


def test_an_image_bomb_is_refused_by_its_header_before_decoding():
    import resource

    bomb = _png_header(20000, 20000)  # 4 kB that would decode to 1.2 GB
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    with pytest.raises(InputError, match=r"picture too large: 20000 x 20000 pixels, more than the 50,000,000"):
        decode_image(bomb)
    assert resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before < 100_000  # kB: nothing decoded
    assert 8000 * 6000 <= MAX_PIXELS  # a 48-megapixel phone photo is read


@pytest.mark.parametrize("data, message", [
    (b"GIF89a" + bytes(100), "unreadable picture: not a PNG, JPEG, BMP, PPM or TIFF picture"),
    (b"", "unreadable picture: not a PNG"),
    (b"\xff\xd8\xff\xe0\x00\x10JFIF", "unreadable picture: not a PNG"),  # a JPEG cut short
    (_png_header(64, 48), "unreadable picture: damaged (its header says 64 x 48 pixels"),
])
def test_what_is_not_a_picture_is_named(data, message):
    with pytest.raises(InputError, match=message.replace("(", r"\(")):
        decode_image(data)


def test_read_picture_names_the_file(tmp_path):
    path = tmp_path / "photo.png"
    path.write_bytes(_png_header(30000, 30000))
    with pytest.raises(InputError) as info:
        read_picture(path)
    assert info.value.file == str(path) and "too large" in str(info.value)
