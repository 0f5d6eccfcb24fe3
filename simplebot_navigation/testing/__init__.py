"""Shared by the tests and the benchmarks: reference implementations to compare against, and the lab's
parameters and sensor scenes. Not used by the navigation stack itself."""
