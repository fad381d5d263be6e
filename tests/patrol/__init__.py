"""Tests (a package, so test modules may share helpers and repeat basenames)."""
