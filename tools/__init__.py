"""A package: run its modules with `/usr/bin/python3 -m` from the repository root (docs/running.md, "Python tools")."""
