"""The REPL: a thin ``cmd.Cmd`` over :class:`~hila_lang.engine.interpreter.Interpreter`.

Commands: ``step [n]``, ``run`` / ``continue`` (until a breakpoint or the end), ``break
[STATE]`` (glob patterns allowed: ``break main/*/draw``; no argument lists them), ``clear
[STATE]``, ``where``, ``icps``, ``explain``, ``vars``, ``path [--plot FILE.png]``, ``fsm``,
``back [n]`` (undo steps: world and simulator restored), ``reload`` (the edited program and
templates, from the same state), ``reset``, ``help``, ``quit``.  An error in a command is
reported and the session goes on, and so does Ctrl-C: it stops a ``run`` (or any command) and
returns to the prompt with the world, the simulator and the hand as they were; at the prompt it
cancels the line.  Reading a pipe, each command is echoed after the prompt, so a transcript
reads like a session; on a terminal,
readline gives history (``~/.hila_history``) and tab completion of commands and state names.
"""

from __future__ import annotations

import cmd
import difflib
import fnmatch
import os
import shlex
import sys
from pathlib import Path

import numpy as np

from ..core.errors import EXIT_INTERRUPTED, HilaError, Interrupted
from ..core.interrupts import Terminated
from ..engine.interpreter import Interpreter
from ..engine.trace import fmt_point, fmt_value
from ..language.environment import Environment

HISTORY = Path(os.path.expanduser("~")) / ".hila_history"


class Repl(cmd.Cmd):
    prompt = "(hila) "

    def __init__(self, interp: Interpreter, stdin=None, stdout=None, load=None) -> None:
        """``load(file) -> (checked, fsm)``: how ``reload`` reads the program again (default: the
        process's environment, :meth:`Environment.load`; the studio's reads inside its folder)."""
        stdin = stdin or sys.stdin
        self.load = load or (lambda file: Environment.default().load(file))
        stdout = stdout or sys.stdout
        super().__init__(stdin=stdin, stdout=stdout)
        self.interp = interp
        self.breakpoints: list[str] = []
        self.no_back = interp.keep_history()  # None, or why 'back' cannot work here
        self.interactive = bool(getattr(stdin, "isatty", lambda: False)())
        self.use_rawinput = self.interactive and stdin is sys.stdin
        if not self.interactive:  # cmd would print the prompt with no newline; precmd echoes instead
            self.prompt = ""
        fsm = interp.fsm
        self.intro = (f"hila repl: {fsm.file}, {len(fsm.states)} states, world {fsm.world}, "
                      f"back end {interp.backend.name}. Type 'help' for commands.\n"
                      f"at {interp.current}")

    # ------------------------------------------------------------------ plumbing
    def cmdloop(self, intro=None) -> None:
        """``cmd``'s loop, where Ctrl-C at the prompt cancels the line instead of ending the session."""
        while True:
            try:
                super().cmdloop(intro)
                return
            except KeyboardInterrupt as stop:
                if isinstance(stop, Terminated):  # SIGTERM, SIGHUP: the session ends (the world saves)
                    raise
                self.say("\ninterrupted: type 'quit' to leave")
                intro = ""

    def say(self, text: str = "") -> None:
        self.stdout.write(text + "\n")
        self.stdout.flush()

    def preloop(self) -> None:
        if self.use_rawinput and not getattr(self, "_history_read", False):
            self._history_read = True
            try:
                # lazy: only this branch needs it
                import readline

                readline.set_completer_delims(" \t\n")
                if HISTORY.is_file():
                    readline.read_history_file(str(HISTORY))
            except (ImportError, OSError):
                pass

    def postloop(self) -> None:
        if self.use_rawinput:
            try:
                # lazy: only this branch needs it
                import readline

                readline.write_history_file(str(HISTORY))
            except (ImportError, OSError):
                pass

    def precmd(self, line: str) -> str:
        if not self.interactive and line != "EOF":
            self.say(f"{Repl.prompt}{line.rstrip()}")
        return line

    def onecmd(self, line: str) -> bool:
        try:
            return bool(super().onecmd(line))
        except HilaError as exc:
            if isinstance(exc, Interrupted) and exc.exit_code != EXIT_INTERRUPTED:  # SIGTERM: end, not go on
                raise
            self.say(str(exc))
        except (ValueError, OSError) as exc:
            self.say(f"error: {exc}")
        except KeyboardInterrupt as stop:  # Ctrl-C between two steps, or in another command (path --plot)
            if isinstance(stop, Terminated):
                raise
            self.say("\ninterrupted")
            self._at()
        return False

    def emptyline(self) -> bool:  # do not repeat the last command
        return False

    def default(self, line: str) -> None:
        word = line.split()[0]
        close = difflib.get_close_matches(word, self.get_names_as_commands(), n=1)
        self.say(f"error: unknown command '{word}'" + (f"; did you mean '{close[0]}'?" if close else "; try 'help'"))

    def get_names(self) -> list[str]:  # hide the EOF handler from 'help' and completion
        return [n for n in super().get_names() if n != "do_EOF"]

    def get_names_as_commands(self) -> list[str]:
        return [n[3:] for n in self.get_names() if n.startswith("do_") and n != "do_EOF"]

    def complete_states(self, text: str, *ignored) -> list[str]:
        return [s for s in self.interp.fsm.states if s.startswith(text)]

    complete_break = complete_clear = complete_states

    # ------------------------------------------------------------------ commands
    def do_step(self, arg: str) -> None:
        """step [N]: execute the next N states (default 1)."""
        try:
            n = int(arg) if arg.strip() else 1
        except ValueError:
            raise ValueError(f"expected 'step' or 'step N' with a whole number N, got {arg.strip()!r}") from None
        if n < 1:
            raise ValueError(f"expected a positive number of steps, got {n}")
        for _ in range(n):
            if self.interp.done:
                self.say("the program has finished; 'reset' to run it again")
                break
            self.say(str(self.interp.step()))
        self._at()

    def do_run(self, arg: str) -> None:
        """run: execute until a breakpoint or the end (Ctrl-C stops it; the session goes on)."""
        if self.interp.done:
            self.say("the program has finished; 'reset' to run it again")
            return
        self.interp.run(until=self._hit, each=lambda entry: self.say(str(entry)))
        if not self.interp.done and self._hit():
            self.say(f"breakpoint: {self.interp.current}")
        self._at()

    def do_continue(self, arg: str) -> None:
        """continue: execute until the next breakpoint or the end (same as run)."""
        self.do_run(arg)

    do_c = do_continue

    def _hit(self, state: str | None = None) -> bool:
        state = self.interp.current if state is None else state
        return any(fnmatch.fnmatchcase(state, b) for b in self.breakpoints)

    def _at(self) -> None:
        self.say("finished" if self.interp.done else f"at {self.interp.current}")

    def do_break(self, arg: str) -> None:
        """break [STATE]: stop before entering STATE (glob patterns allowed); no argument lists them."""
        pattern = arg.strip()
        if not pattern:
            self.say("breakpoints: " + (", ".join(self.breakpoints) if self.breakpoints else "none"))
            return
        states = list(self.interp.fsm.states)
        if not any(fnmatch.fnmatchcase(s, pattern) for s in states):
            close = difflib.get_close_matches(pattern, states, n=1)
            raise ValueError(f"no state matches '{pattern}'" + (f"; did you mean '{close[0]}'?" if close else ""))
        if pattern not in self.breakpoints:
            self.breakpoints.append(pattern)
        self.say(f"breakpoint set: {pattern}")

    def do_clear(self, arg: str) -> None:
        """clear [STATE]: remove one breakpoint, or all of them."""
        pattern = arg.strip()
        if pattern and pattern not in self.breakpoints:
            raise ValueError(f"no breakpoint '{pattern}'")
        self.breakpoints = [b for b in self.breakpoints if pattern and b != pattern]
        self.say("breakpoints: " + (", ".join(self.breakpoints) if self.breakpoints else "none"))

    def do_where(self, arg: str) -> None:
        """where: the current state, its program line and where the hand is."""
        it = self.interp
        self.say(f"step {it.trace.total}, hand at {fmt_point(it.hand())}")
        if it.done:
            self.say("finished")
            return
        st = it.state
        self.say(f"at {st.name} ({st.kind}): {st.describe()}")
        if st.line:
            # lazy: only this branch needs it
            from ..language.source import source_line

            src = source_line(it.checked.program.source, st.line) or ""
            self.say(f"  {it.fsm.file}:{st.line}: {src.strip()}")

    def do_icps(self, arg: str) -> None:
        """icps: the ICP bindings of the current run state, or of the last run."""
        it = self.interp
        if not it.done and it.state.kind == "run":
            icps, what = it._guard(it.state, lambda: it.bind(it.state)), f"{it.current} will bind"
        elif it.last_icps:
            icps, what = it.last_icps, "the last run bound"
        else:
            self.say("no ICPs yet: no run state is current or has run")
            return
        self.say(f"{what}:")
        for k, v in icps.items():
            self.say(f"  {k:<12} = {fmt_point(v)}")
        last = it.last_run
        if last is not None and last.step_result is not None:  # what OSILA did with the last run's pairs
            # lazy: only this branch needs it
            from ..hierarchy.explain import pairs_line

            pairs = getattr(last.step_result.result, "pairs", None)
            if pairs is not None:
                where = "" if what.startswith("the last run") else f"the last run ({last.state}): "
                self.say("  " + where + pairs_line(pairs, list(it.last_icps)))

    def do_explain(self, arg: str) -> None:
        """explain: what OSILA does in the current run state (or did in the last run): the ICP
        pairs, the map and its fallback, the rounds of plan adjustment and why each was needed."""
        for line in self.interp.explain():
            self.say(line)

    def do_vars(self, arg: str) -> None:
        """vars: the program's variables and their values."""
        if not self.interp.env:
            self.say("no variables yet")
        for slot, v in self.interp.env.items():
            self.say(f"  {slot} = {fmt_value(v)}")

    def do_path(self, arg: str) -> None:
        """path [--plot FILE.png]: the last generated path (and a picture of it)."""
        it = self.interp
        if it.last_path is None:
            self.say("no path yet: no run state has run")
            return
        words = shlex.split(arg)
        if words and (words[0] != "--plot" or len(words) != 2):
            raise ValueError("usage: path [--plot FILE.png]")
        p = it.last_path
        last = it.last_run
        self.say(f"{last.state}: {len(p)} points, {fmt_point(p[0])} -> {fmt_point(p[-1])}, "
                 f"length {float(np.linalg.norm(np.diff(p, axis=0), axis=1).sum()):.3f} m")
        if words:
            # lazy: only this branch needs it
            from .plot import plot_path

            out = plot_path(p, words[1], icps=it.last_icps, executed=last.executed, title=last.state)
            self.say(f"wrote {out}")

    def do_fsm(self, arg: str) -> None:
        """fsm: the state machine, '>' at the current state."""
        for line in self.interp.fsm.to_text().splitlines():
            name = line.strip().split(" ")[0] if line.startswith("  ") else None
            mark = ">" if name == self.interp.current and not self.interp.done else " "
            self.say(mark + line[1:] if line.startswith("  ") else line)

    def do_back(self, arg: str) -> None:
        """back [N]: undo the last N steps (default 1): the world, the simulator and the program's
        variables are as they were, so the same step can run again (after a 'reload', say)."""
        try:
            n = int(arg) if arg.strip() else 1
        except ValueError:
            raise ValueError(f"expected 'back' or 'back N' with a whole number N, got {arg.strip()!r}") from None
        self.say(f"{self.interp.back(n)}; hand at {fmt_point(self.interp.hand())}")

    def do_reload(self, arg: str) -> None:
        """reload: re-read the program and the templates it imports and go on from the same state
        (the world and the back end keep theirs).  A program that does not load is reported and the
        old one keeps running."""
        file = self.interp.fsm.file
        try:
            checked, fsm = self.load(file)
        except HilaError as exc:
            self.say(str(exc))
            self.say(f"reload failed: the program as it was keeps running (at {self.interp.current})")
            return
        where = self.interp.reload(checked, fsm)
        files = ", ".join(str(p) for p in checked.template_files.values())
        self.say(f"reloaded {file} ({len(fsm.states)} states; templates {files or 'none'}); {where}")
        for b in self.breakpoints:
            if not any(fnmatch.fnmatchcase(s, b) for s in fsm.states):
                self.say(f"note: breakpoint {b} matches no state of the new program")

    def do_reset(self, arg: str) -> None:
        """reset: back to the start state, variables cleared, hand back to its start."""
        self.interp.reset()
        self.say(f"reset; at {self.interp.current}")

    def do_quit(self, arg: str) -> bool:
        """quit: leave the REPL."""
        return True

    do_exit = do_quit

    def do_EOF(self, arg: str) -> bool:
        """End of input: leave the REPL."""
        self.say("")
        return True
