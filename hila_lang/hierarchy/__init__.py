"""HILA: hierarchical generation on top of OSILA (the floor between the language and OSILA).

- ``learn``     one demonstration -> a template cut into tagged sub-templates (``hila learn``'s)
- ``step``      THE HILA step: bind a (sub-)template to scene points and the hand, run OSILA
- ``generate``  sequences of steps stitched into one path; step names resolved to templates
- ``explain``   what one step did, in words (``hila explain``, the REPL's ``explain``)
"""
