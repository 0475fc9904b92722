"""The compendium around ``ocpkit``: the seeds' problems, their published values, the studies behind each notebook.

``ocpkit`` is the library and never reads this repository; this package does:
``paths`` (the repository and where outputs go), ``paper`` (published values in
``data/paper``), ``problems`` (the seeds' test problems, constants from
``data/problems``), ``studies`` (one module per notebook's computations),
``tables`` and ``plotting`` (house style), ``checks`` (asserted key numbers), and the
run machinery, each layer importing only those below it: ``notebook_source`` (a
notebook's parameters and code, read from its file), ``provenance`` (git state,
machine, run folders and records), ``outputs`` (what a run writes) and ``report``
(the HTML report), then ``notebooks`` (the papermill runner, publishing, the
command line). ``docs/layout.md`` lists every module.
"""
