"""Task calls, seen whole before compiling: no recursion, and an inlined program of bounded size.

Tasks are compiled inline (each call site gets its own copy of the task's states), so the call
graph must be acyclic, and what inlining makes of it must stay within two limits:

- :data:`~hila_lang.language.limits.MAX_STATES` states in the FSM -- a task called twice by
  a task called twice ... doubles at every level, so 30 levels would make a billion states;
- :data:`~hila_lang.language.limits.MAX_NESTING` levels of blocks and expressions with every
  call opened in place (the compiler recurses through calls as through blocks).

Everything here walks without recursion and visits each task once, whatever the program.
"""

from __future__ import annotations

from dataclasses import dataclass

from . import ast as A

from .limits import MAX_NESTING, MAX_STATES


@dataclass
class _Body:
    """What one task (or main) contributes: its call sites and its own size."""

    sites: list  # [(CallStmt, block level of the call in this body)]
    states: int  # states of its own statements, calls counted once each
    depth: int  # its own deepest nesting (blocks + expression levels)
    inlined_states: int = 0
    inlined_depth: int = 0
    deepest_call: A.CallStmt | None = None  # the call on its deepest inlined chain


def _states_of(s) -> int:
    """States a statement compiles to itself (a call's task not included)."""
    if isinstance(s, A.IfStmt):
        return len(s.branches)
    if isinstance(s, A.RepeatStmt):
        return 3  # counter, test, decrement
    return 1


def _body(node, nesting: bool = True) -> _Body:
    """``nesting=False`` skips measuring its own nesting (main's was measured by the parser)."""
    # lazy: loads lark, which importing this module does not
    from .transformer import deepest

    sites, states = [], 0
    stack = [(s, 1) for s in reversed(node.body)]
    while stack:
        s, level = stack.pop()
        states += _states_of(s)
        if isinstance(s, A.CallStmt):
            sites.append((s, level))
        for c in reversed(A.children(s)):
            if isinstance(c, A.STATEMENTS):
                stack.append((c, level + 1))
    found = deepest([node]) if nesting else None
    return _Body(sites, states, found[1] + found[2] if found else 0)


def _count(n: int) -> str:
    return f"{n:,}" if n < 10**12 else f"about 10^{len(str(n)) - 1}"


def _chain_text(names: list[str]) -> str:
    if len(names) > 8:
        names = names[:4] + ["..."] + names[-3:]
    return " -> ".join(names)


def check_calls(tasks: dict, main: A.MainDef, error) -> list[str]:
    """Check the calls of ``main`` and ``tasks`` (name -> TaskDef); returns the names of the
    tasks main never reaches.  ``error(message, pos, hint)`` makes the CheckError to raise.

    Raises (through ``error``): a task that calls itself, directly or through others; a program
    whose inlined FSM would exceed :data:`MAX_STATES` states or nest deeper than
    :data:`~hila_lang.language.limits.MAX_NESTING` levels.
    """
    bodies = {"main": _body(main, nesting=False)}
    path, on_path = ["main"], {"main"}
    stack = [iter(bodies["main"].sites)]
    while stack:
        caller = path[-1]
        for call, _ in stack[-1]:
            callee = call.task
            if callee in on_path:
                chain = path[1:]
                cycle = " -> ".join(chain[chain.index(callee):] + [callee])
                raise error(f"task '{callee}' calls itself ({cycle})", call.pos,
                            "tasks are compiled inline into the FSM, so recursion is not allowed; use a loop")
            if callee not in bodies:
                bodies[callee] = _body(tasks[callee])
                path.append(callee)
                on_path.add(callee)
                stack.append(iter(bodies[callee].sites))
                break
        else:  # every callee of ``caller`` is done: size it up
            stack.pop()
            on_path.discard(path.pop())
            me = bodies[caller]
            me.inlined_states, me.inlined_depth = me.states, me.depth
            for call, level in me.sites:
                callee = bodies[call.task]
                me.inlined_states += callee.inlined_states
                if level + callee.inlined_depth > me.inlined_depth:
                    me.inlined_depth, me.deepest_call = level + callee.inlined_depth, call
    top = bodies["main"]
    if top.inlined_depth > MAX_NESTING:
        chain, at, call = ["main"], top, None
        while at.deepest_call is not None:
            call = call or at.deepest_call
            chain.append(at.deepest_call.task)
            at = bodies[at.deepest_call.task]
        raise error(f"task calls nest too deeply: {_chain_text(chain)} inlines to {top.inlined_depth} "
                    f"levels of blocks and expressions (at most {MAX_NESTING})", call.pos,
                    "tasks are compiled inline: call fewer tasks inside each other")
    total = top.inlined_states + 1  # and the end state
    if total > MAX_STATES and not top.sites:  # main alone is too long (a 5 MB program): no call to blame
        raise error(f"the program would compile to {_count(total)} states (at most {MAX_STATES:,})", main.pos,
                    "split the work into a task called in a loop")
    if total > MAX_STATES:
        call, _ = max(top.sites, key=lambda site: bodies[site[0].task].inlined_states)
        raise error(f"the program would compile to {_count(total)} states (at most {MAX_STATES:,}): every "
                    f"call copies its task's states, and this call alone copies "
                    f"{_count(bodies[call.task].inlined_states)}", call.pos,
                    "a task called from many places inside tasks called from many places multiplies; "
                    "loop over one call instead")
    return [name for name in tasks if name not in bodies]
