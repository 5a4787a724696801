"""The ``aquafish`` command line: one entry point dispatching to the project's packages."""
