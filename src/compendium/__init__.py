"""The compendium around ``ocpkit``: the seeds' problems, their published values, the studies behind each notebook.

``ocpkit`` is the library and never reads this repository; this package does:
``paths`` (the repository and where outputs go), ``paper`` (published values in
``data/paper``), ``problems`` (the seeds' test problems, constants from
``data/problems``), ``studies`` (one module per notebook's computations),
``tables`` and ``plotting`` (house style), ``checks`` (asserted key numbers) and
``notebooks`` (the papermill runner and report).
"""
