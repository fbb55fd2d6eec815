"""Template dataclass, sub-templates and the YAML format (round trip, validation errors)."""

from pathlib import Path

import numpy as np
import pytest

from hila_lang.core.errors import InputError
from hila_lang.osila.template import Segment, Template, load_template, save_template

DATA = Path(__file__).parent / "data" / "core"


def make(T=20, dim=3, times=True, seed=0):
    rng = np.random.default_rng(seed)
    path = rng.normal(0, 1, (T, dim)) / 3.0  # floats with full-precision mantissas
    icps = {"cell.tl": rng.normal(0, 1, dim), "hand": path[0].copy(), "tiny": np.full(dim, 1e-17)}
    segs = [Segment("reach", 0, 5), Segment("draw", 5, 15, True), Segment("retract", 15, T)]
    return Template("circle", path, icps, np.cumsum(rng.uniform(0.01, 0.1, T)) if times else None, segs,
                    description="synthetic: seeded normal noise", units="m")


@pytest.mark.parametrize("dim,times", [(2, False), (3, True)])
def test_yaml_round_trip_is_lossless(tmp_path, dim, times):
    t = make(dim=dim, times=times)
    out = save_template(t, tmp_path / "sub" / "circle.yaml")
    back = load_template(out)
    assert back.name == t.name and back.description == t.description and back.units == t.units
    np.testing.assert_array_equal(back.path, t.path)  # bit-exact
    assert list(back.icps) == list(t.icps)
    for k in t.icps:
        np.testing.assert_array_equal(back.icps[k], t.icps[k])
    assert (back.times is None) == (t.times is None)
    if times:
        np.testing.assert_array_equal(back.times, t.times)
    assert back.segments == t.segments
    # saving again gives the same bytes
    again = save_template(back, tmp_path / "again.yaml")
    assert again.read_bytes() == out.read_bytes()


def test_file_is_human_readable(tmp_path):
    text = save_template(make(T=20, times=False), tmp_path / "d.yaml").read_text()
    assert "hila_template: 1" in text
    assert "- {tag: draw, start: 5, stop: 15, contact: true}" in text
    assert "\n  cell.tl: [" in text


def test_hand_edit_moves_segment_boundary(tmp_path):
    f = save_template(make(), tmp_path / "c.yaml")
    f.write_text(f.read_text().replace("stop: 5,", "stop: 7,").replace("start: 5,", "start: 7,").replace("tag: draw", "tag: circle"))
    t = load_template(f)
    assert t.tags() == ["reach", "circle", "retract"]
    assert (t.segment("circle").start, t.segment("circle").stop) == (7, 15)


def test_sub_template():
    t = make()
    sub = t.sub("draw")
    np.testing.assert_array_equal(sub.path, t.path[5:15])
    np.testing.assert_array_equal(sub.times, t.times[5:15])
    assert list(sub.icps) == ["cell.tl", "hand", "tiny", "start", "end"]
    np.testing.assert_array_equal(sub.icps["start"], t.path[5])
    np.testing.assert_array_equal(sub.icps["end"], t.path[14])
    assert sub.name == "circle.draw" and sub.segments == [Segment("draw", 0, 10, True)]
    with pytest.raises(KeyError, match=r"no segment 'drw'; known: \['reach', 'draw', 'retract'\]"):
        t.sub("drw")


def write(tmp_path, text):
    f = tmp_path / "t.yaml"
    f.write_text(text)
    return f


GOOD = """hila_template: 1
name: demo
icps:
  a: [0.0, 0.0]
  b: [1.0, 0.0]
segments:
- {tag: one, start: 0, stop: 2, contact: false}
- {tag: two, start: 2, stop: 3, contact: true}
path:
- [0.0, 0.0]
- [0.5, 0.5]
- [1.0, 0.0]
"""


def test_good_fixture_loads(tmp_path):
    t = load_template(write(tmp_path, GOOD))
    assert t.tags() == ["one", "two"] and t.path.shape == (3, 2)


@pytest.mark.parametrize(
    "edit,message",
    [
        (lambda s: s.replace("  b: [1.0, 0.0]", "  a: [1.0, 0.0]"), r"t\.yaml:5:3: error: .*duplicate key 'a' \(first defined at line 4\)"),
        (lambda s: s + "colour: red\n", r"t\.yaml: error: unknown field 'colour'; expected fields: hila_template, name"),
        (lambda s: s.replace("hila_template: 1", "hila_template: 2"), r"unsupported template version in field 'hila_template': expected 1, got 2"),
        (lambda s: s.replace("stop: 2, contact: false", "stop: 1, contact: false"), r"segment 'two' \(field 'segments\[1\]'\) leaves a gap: expected start = 1, got 2"),
        (lambda s: s.replace("start: 2, stop: 3", "start: 1, stop: 3"), r"segment 'two' \(field 'segments\[1\]'\) overlaps the previous one: expected start = 2, got 1"),
        (lambda s: s.replace("stop: 3, contact", "stop: 4, contact"), r"out of range: stop 4 > path length 3"),
        (lambda s: s.replace("tag: two", "tag: one"), r"duplicate tag 'one' in field 'segments\[1\]\.tag'"),
        (lambda s: s.replace("  b: [1.0, 0.0]", "  b: [1.0, 0.0, 2.0]"), r"expected field 'icps\.b' as 2 numbers \(the path's D\), got shape \(3,\)"),
        (lambda s: s.replace("- [0.5, 0.5]", "- [0.5]"), r"expected field 'path' as rows of equal length, row 1 is \[0\.5\]"),
        (lambda s: s.replace("- [0.5, 0.5]", "- [0.5, .nan]"), r"expected finite field 'path'"),
        (lambda s: s.replace("name: demo\n", ""), r"missing field 'name'"),
        (lambda s: s.replace("{tag: two, start: 2, stop: 3, contact: true}", "{tag: two, start: 2, stop: 3, contact: yes please}"), r"expected field 'segments\[1\]\.contact' as true or false, got 'yes please'"),
        (lambda s: s[: s.index("- [0.5")] + "- [0.5, 0.", r"t\.yaml:11:11: error: template is not valid YAML: expected ',' or ']'"),
        (lambda s: s[: s.index("- [0.5")], r"segment 'one' \(field 'segments\[0\]'\) is out of range: stop 2 > path length 1"),
        (lambda s: "just some words, not a template\n", r"expected a hila template \(a mapping with 'hila_template: 1'\), got str"),
        (lambda s: "", r"got an empty file"),
        (lambda s: "a: [1, 2\nb: }", r"t\.yaml:\d+:\d+: error: template is not valid YAML"),
    ],
)
def test_bad_template_files_name_file_and_field(tmp_path, edit, message):
    with pytest.raises(InputError, match=message):
        load_template(write(tmp_path, edit(GOOD)))


def test_truncated_file_reports_segment_or_path(tmp_path):
    text = save_template(make(T=30), tmp_path / "full.yaml").read_text()
    cut = text[: len(text) * 2 // 3]
    with pytest.raises(InputError, match=r"t\.yaml:\d+:\d+: error: template is not valid YAML"):
        load_template(write(tmp_path, cut))
    # cut at a line boundary: valid YAML, but the rows no longer match
    cut = cut[: cut.rindex("\n", 0, cut.rindex("\n")) + 1]
    with pytest.raises(InputError, match=r"t\.yaml: error: expected field 'times' with one entry per path row"):
        load_template(write(tmp_path, cut))


def test_binary_and_missing_files(tmp_path):
    f = tmp_path / "t.yaml"
    f.write_bytes(b"\x89PNG\r\n\x1a\n\x00\xff")
    with pytest.raises(InputError, match=r"template is not UTF-8 text"):
        load_template(f)
    with pytest.raises(InputError, match=r"nope\.yaml: error: template not found"):
        load_template(tmp_path / "nope.yaml")


def test_constructor_validates():
    with pytest.raises(InputError, match=r"field 'times' strictly increasing, got 1.0 then 1.0 at index 2"):
        Template("x", np.zeros((3, 2)), {}, times=[0.0, 1.0, 1.0])
    with pytest.raises(InputError, match=r"field 'segments' does not cover the path: last stop is 2, path length is 3"):
        Template("x", np.zeros((3, 2)), {}, segments=[Segment("a", 0, 2)])
    with pytest.raises(InputError, match=r"expected field 'path' of shape \(T, D\)"):
        Template("x", np.zeros((3, 5)), {})


def test_fixture_template_loads():
    t = load_template(DATA / "circle.yaml")
    assert t.tags() == ["reach", "draw", "retract"] and t.segment("draw").contact
    assert t.path.shape == (200, 3) and len(t.icps) == 5


from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402
from hypothesis.extra.numpy import arrays  # noqa: E402

finite = st.floats(min_value=-1e6, max_value=1e6, allow_nan=False, width=64)  # template.MAX_COORDINATE


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(path=arrays(float, st.tuples(st.integers(1, 6), st.sampled_from([2, 3])), elements=finite), data=st.data())
def test_round_trip_any_floats(tmp_path, path, data):
    D = path.shape[1]
    icp = data.draw(arrays(float, (D,), elements=finite))
    cut = data.draw(st.integers(1, len(path)))
    segs = [Segment("a", 0, cut)] + ([Segment("b", cut, len(path), True)] if cut < len(path) else [])
    t = Template("h", path, {"p": icp}, segments=segs)
    back = load_template(save_template(t, tmp_path / "h.yaml"))
    np.testing.assert_array_equal(back.path, path)
    assert np.signbit(back.path).tolist() == np.signbit(path).tolist()  # -0.0 survives
    np.testing.assert_array_equal(back.icps["p"], icp)
    assert back.segments == segs
