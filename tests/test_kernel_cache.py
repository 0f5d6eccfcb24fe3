"""A numba cache is dropped when any module of its group changes, and kept otherwise."""

from simplebot_navigation.kernel_cache import drop_stale_kernel_caches


def test_a_change_in_one_module_drops_the_caches_of_its_whole_group(tmp_path):
    (tmp_path / "callee.py").write_text("X = 1\n")
    (tmp_path / "caller.py").write_text("Y = 2\n")
    cache = tmp_path / "__pycache__"
    group = ("callee", "caller")
    drop_stale_kernel_caches(tmp_path, group)
    cached = [cache / "caller.solve-12.py311.nbi", cache / "caller.solve-12.py311.1.nbc", cache / "callee.f-3.py311.nbi"]
    for path in cached:
        path.write_bytes(b"compiled")
    drop_stale_kernel_caches(tmp_path, group)
    assert all(path.exists() for path in cached)          # nothing changed: the caches stay
    (tmp_path / "callee.py").write_text("X = 3\n")
    drop_stale_kernel_caches(tmp_path, group)
    assert not any(path.exists() for path in cached)      # the caller inlined the old callee: gone too


def test_a_change_in_a_file_of_another_package_that_the_group_inlines_drops_its_caches(tmp_path):
    package, shared = tmp_path / "package", tmp_path / "shared_kernels.py"
    package.mkdir()
    (package / "caller.py").write_text("Y = 2\n")
    shared.write_text("def inside(): pass\n")
    drop_stale_kernel_caches(package, ("caller",), inlined=(shared,))
    cached = package / "__pycache__" / "caller.solve-12.py311.1.nbc"
    cached.write_bytes(b"compiled")
    drop_stale_kernel_caches(package, ("caller",), inlined=(shared,))
    assert cached.exists()
    shared.write_text("def inside(): return True\n")
    drop_stale_kernel_caches(package, ("caller",), inlined=(shared,))
    assert not cached.exists()
