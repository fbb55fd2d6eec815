"""The stepping engine: runs a compiled FSM (:mod:`hila_lang.language.fsm`) one state at a time
over a world and a back end.  The loop ticks; each state class's executor does the state
(py_trees' habit: the tree ticks, each behaviour holds its own ``update``).

One line each:

- ``interpreter``  the step loop: step, run to a breakpoint, Ctrl-C, errors located at their line
- ``executors``    one executor per state class, found through the class (set, call, wait, branch, end)
- ``run``          the executor of ``run`` states: bind the ICPs, one HILA step, move the hand
- ``tracking``     a run whose ICPs stay live while it runs (``track``): look, warp the rest again, blend it in
- ``scene``        the run's variables and point names, and the expression evaluator
- ``trace``        what each step did, the newest entries kept, values as text
- ``history``      going back and reloading
"""
