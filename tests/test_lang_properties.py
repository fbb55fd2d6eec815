"""Properties over generated programs (hypothesis), run against the scripted world:

1. ``hila check`` never raises anything but hila's own error -- located (file, line, column)
   when it is about the program, naming ``--set`` when it is about a setting;
2. a program ``check`` accepts, run with the same settings on the dry back end, never fails with
   an unknown name, a point of the wrong size or a bad option.  (It may fail otherwise: a script
   that runs out of answers, a division by zero, a condition that is not true or false.)

The programs mix good and bad names (questions, events, world points, templates, tags), 2-D and
3-D points (literals, ``point`` s, ``let`` s, a world's answers, task parameters), a 2-D template
(which the scripted world has no surface for) and good and bad settings.  Examples are few and
small, so the suite stays fast.
"""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from hila_lang.core.errors import CheckError, HilaError, HilaRuntimeError, HilaSyntaxError, InputError, UnknownNameError
from hila_lang.language import load_program
from hila_lang.session.runner import finish, prepare
from hila_lang.plugins.options import RunOptions
from hila_lang.osila.template import Template, load_template, save_template

ROOT = Path(__file__).resolve().parent.parent

SCRIPT = """\
points: {shelf.low: [0.30, -0.10, 0.60], shelf.high: [0.30, -0.10, 0.70]}
answers:
  ready: [true, false, true, false, true, false, true, false]
  where: [[0.32, -0.05, 0.62], [0.28, -0.12, 0.61], [0.31, -0.08, 0.60], [0.30, -0.02, 0.63]]
  flat: [[0.3, 0.1], [0.2, 0.1]]
  count: 2
events: {bell: [1, 2, 3, 4, 5, 6]}
"""

GOOD_POINTS = ["(0.30, -0.10, 0.60)", "(0.34, -0.02, 0.62)", "p3", "shelf.low", "shelf.high", "hand", "v",
               "ask where", "home", "none"]
BAD_POINTS = ["(0.3, 0.1)", "p2", "shelf.lwo", "w", "ask flat", "ask wehre"]  # 2-D, or unknown names
POINT = st.sampled_from(GOOD_POINTS * 4 + BAD_POINTS)  # mostly good: many programs pass check and run
RUN = st.tuples(st.sampled_from(["reach.reach"] * 4 + ["reach.back"] * 4 + ["reach.bakc", "flat", "rech.reach"]),
                POINT, POINT).map(lambda t: f"run {t[0]}(object = {t[1]}, home = {t[2]})")
SIMPLE = st.one_of(
    RUN,
    POINT.map(lambda p: f"touch({p})"),
    st.sampled_from(["wait bell", "let n = ask count", "let e = wait bell", "let v = (0.31, -0.09, 0.61)"] * 3
                    + ["wait bel", "let r = ask redy", "let q = 1 / 0", "let w = (0.3, 0.1)"]),
)
STATEMENT = st.recursive(
    SIMPLE,
    lambda inner: st.one_of(
        st.lists(inner, min_size=1, max_size=3).map(lambda b: "if ask ready {\n" + "\n".join(b) + "\n}"),
        st.lists(inner, min_size=1, max_size=3).map(lambda b: "repeat 2 {\n" + "\n".join(b) + "\n}"),
        st.lists(inner, min_size=1, max_size=3).map(lambda b: "until ask ready {\n" + "\n".join(b) + "\n}")),
    max_leaves=6)
SETTINGS = st.one_of(
    st.just({}), st.just({"osila.threshold": "0.002"}), st.just({"osila.rounds": "3", "hand": "0.2,-0.2,0.7"}),
    st.dictionaries(st.sampled_from(["osila.threshold", "osila.rounds", "osila.shells", "osila.bogus", "hand", "bogus"]),
                    st.sampled_from(["0.002", "abc", "-1", "0", "3", "1,2,3", "[1, 2]"]), min_size=1, max_size=2))

HEADER = """\
import reach
import "flat.yaml" as flat
point p3 = (0.18, -0.25, 0.75)
point p2 = (0.18, -0.25)
point home = (0.18, -0.25, 0.75)
task touch(where) {
    run reach.reach(object = where, home = home)
}
main {
    let v = (0.31, -0.09, 0.61)
    let w = (0.3, 0.1)
"""

NEVER = ("has no question", "has no event", "unknown scene point", "-D but ICP", "-D point",
         "2-D template", "unknown setting", "bad value for --set")


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("props")
    (tmp / "world.yaml").write_text(SCRIPT)
    reach = load_template(ROOT / "primitives" / "reach.yaml")
    save_template(Template("flat", reach.path[:, :2].copy(), {k: v[:2].copy() for k, v in reach.icps.items()},
                           times=reach.times, segments=reach.segments, description="reach, flat"), tmp / "flat.yaml")
    (tmp / "primitives").mkdir()
    (tmp / "primitives" / "reach.yaml").write_text((ROOT / "primitives" / "reach.yaml").read_text())
    return tmp


@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
@given(body=st.lists(STATEMENT, min_size=1, max_size=4), pairs=SETTINGS)
def test_check_accepts_only_what_runs_without_unknown_names_sizes_or_options(folder, body, pairs):
    prog = folder / "p.hila"
    prog.write_text(HEADER + "\n".join(body) + "\n}\n")
    given_settings = {"script": str(folder / "world.yaml"), **pairs}
    try:
        load_program(prog, settings=given_settings, backend="dry")
    except (CheckError, HilaSyntaxError) as exc:
        assert exc.file == str(prog) and exc.line and exc.column, str(exc)
        return
    except InputError as exc:  # a setting: named, not located in the program
        assert any(key in exc.message for key in pairs), str(exc)
        return
    except HilaError as exc:  # pragma: no cover - the property's failure
        pytest.fail(f"check raised an unlocated {type(exc).__name__}: {exc}")
    options = RunOptions(settings=given_settings, stdout=io.StringIO())
    interp = prepare(prog, options, "dry")
    try:
        interp.run(max_steps=60)
    except UnknownNameError as exc:  # pragma: no cover - the property's failure
        pytest.fail(f"check accepted a name the run does not know: {exc}")
    except HilaRuntimeError as exc:
        assert not any(m in exc.message for m in NEVER), f"check accepted what the run refused: {exc}"
    finally:
        finish(interp)
    assert np.isfinite(interp.hand()).all()


def test_the_generator_reaches_both_sides(folder):
    """The property is not vacuous: these hand-picked members of the generated space are
    accepted and run, or refused by check, as expected."""
    accepted = HEADER + "touch(ask where)\nrun reach.back(object = shelf.low, home = v)\nwait bell\n}\n"
    refused = {
        "touch((0.3, 0.1))": "through parameter 'where' of task 'touch'",
        "run reach.reach(object = ask flat, home = home)": "is bound to a 2-D point",
        "run flat(object = shelf.low, home = home)": "has no drawing surface",
        "let r = ask redy": "has no question 'redy'",
    }
    script = {"script": str(folder / "world.yaml")}
    prog = folder / "q.hila"
    prog.write_text(accepted)
    interp = prepare(prog, RunOptions(settings=script, stdout=io.StringIO()), "dry")
    interp.run()
    assert interp.done
    finish(interp)
    for statement, message in refused.items():
        prog.write_text(HEADER + statement + "\n}\n")
        with pytest.raises(CheckError, match=message.replace("(", r"\(").replace(")", r"\)")):
            load_program(prog, settings=script)
