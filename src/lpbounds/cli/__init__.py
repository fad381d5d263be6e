"""The ``lpbounds`` command line (one module per subcommand)."""
