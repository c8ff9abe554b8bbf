"""Progressive execution: determinism, threads, stopping rules, cancellation, memory."""

import numpy as np
import pytest

from engine import render
from engine.film import Film
from tests import scenes

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def cbspheres():
    return scenes.cbspheres()


def test_same_seed_same_image(cbspheres):
    st = scenes.settings(width=48, height=36, samples=3)
    a, b = render(cbspheres, st), render(cbspheres, st)
    assert np.array_equal(a.combined, b.combined)


def test_thread_count_and_chunking_do_not_change_the_image(cbspheres):
    """Samples depend on (seed, pixel, index) only, so the image is bit-identical for
    any thread count or chunk size (stronger than statistical equality)."""
    base = dict(width=48, height=36, samples=3)
    one = render(cbspheres, scenes.settings(threads=1, **base))
    two = render(cbspheres, scenes.settings(threads=2, chunk_pixels=500, **base))
    assert np.array_equal(one.combined, two.combined)


def test_different_seeds_agree_statistically(cbspheres):
    st = dict(width=32, height=24, samples=16)
    a = render(cbspheres, scenes.settings(seed=1, **st))
    b = render(cbspheres, scenes.settings(seed=2, **st))
    assert not np.array_equal(a.combined, b.combined)
    lum = np.array([0.2126, 0.7152, 0.0722])
    diff = (a.combined[..., :3] - b.combined[..., :3]) @ lum
    se = np.sqrt(a.error.astype(float) ** 2 + b.error.astype(float) ** 2)
    z = diff.sum() / np.sqrt((se ** 2).sum())
    assert abs(z) < 4


def test_progressive_callbacks_and_sample_limit(cbspheres):
    seen = []
    r = render(cbspheres, scenes.settings(width=24, height=18, samples=4),
               on_pass=lambda p: seen.append((p.samples, p.progress, p.combined.shape)))
    assert [s for s, _, _ in seen] == [1, 2, 3, 4]
    assert seen[-1][1] == 1.0 and seen[0][2] == (18, 24, 4)
    assert r.samples == 4 and r.stop_reason == "samples" and not r.cancelled


def test_cancel_keeps_the_finished_passes(cbspheres):
    passes = []
    r = render(cbspheres, scenes.settings(width=24, height=18, samples=100),
               on_pass=lambda p: passes.append(p.combined.copy()),
               should_stop=lambda: len(passes) >= 3)
    assert r.cancelled and r.samples == 3 and r.stop_reason == "cancelled"
    assert np.array_equal(r.combined, passes[-1]) and r.combined[..., :3].mean() > 0


def test_time_limit_and_target_error_stop_the_render(cbspheres):
    r = render(cbspheres, scenes.settings(width=24, height=18, samples=10_000, time_limit=0.5))
    assert r.stop_reason == "time limit" and r.samples < 10_000
    r = render(cbspheres, scenes.settings(width=24, height=18, samples=10_000, target_error=0.3))
    assert r.stop_reason == "target error" and 0 < r.relative_error <= 0.3
    assert r.samples >= len(r.replicate_ids)  # trusted once every replicate has a sample


def test_output_layout_and_passes(cbspheres):
    r = render(cbspheres, scenes.settings(width=40, height=30, samples=2))
    assert r.combined.dtype == np.float32 and r.combined.shape == (30, 40, 4)
    assert np.all(r.combined[..., 3] == 1.0)
    for a in (r.combined, r.depth, r.normal, r.error):
        assert np.isfinite(a).all()
    # Row 0 is the bottom: the floor (near, bright-ish) is low, the emitter high.
    assert r.depth[0].mean() < r.depth[-1].mean() or r.combined[-3:, :, :3].max() > 5
    assert r.combined[-6:, 15:25, :3].max() >= 5.0  # the ceiling emitter shows near the top
    # Normals average across edges; away from them they are unit vectors.
    assert np.median(np.linalg.norm(r.normal[r.depth < 1e9], axis=-1)) == pytest.approx(1.0)


def test_film_replicate_estimate_matches_numpy(monkeypatch):
    """Each pixel is the mean of its samples, and its own variance the spread of its R
    replicate means over R (R - 1); with unequal counts, the count-weighted forms."""
    from engine import film as film_module
    monkeypatch.setattr(film_module, "POOL_RADIUS", 0)  # each pixel's own estimate
    rng = np.random.default_rng(4)
    film = Film(3, 2, replicates=(0, 1, 2, 3))
    samples = rng.random((4 * 5, 6, 3))
    for i, s in enumerate(samples):
        film.add(np.arange(6), i % 4, s, np.ones(6), np.zeros((6, 3)))
    est = film.estimate()
    assert np.allclose(est.combined, samples.mean(axis=0), rtol=1e-6)
    reps = samples.reshape(5, 4, 6, 3).mean(axis=0)  # (replicate, pixel, channel)
    assert np.allclose(est.variance, reps.var(axis=0, ddof=1) / 4, rtol=1e-5)
    assert est.dof == 3
    # The samples' spread within their replicates, as if independent: the pooled
    # within-replicate variance (N - R degrees of freedom) over N.
    lum = np.array([0.2126, 0.7152, 0.0722])
    y = samples.reshape(5, 4, 6, 3) @ lum
    independent = ((y - y.mean(axis=0)) ** 2).sum(axis=(0, 1)) / (20 - 4) / 20
    assert est.independent_relative_error == pytest.approx(
        np.sqrt(independent.mean()) / y.mean(), rel=1e-4)
    # One more sample for replicate 0 only: weights 6, 5, 5, 5.
    extra = rng.random((6, 3))
    film.add(np.arange(6), 0, extra, np.ones(6), np.zeros((6, 3)))
    est = film.estimate()
    counts = np.array([6, 5, 5, 5.0])
    means = reps.copy()
    means[0] = (reps[0] * 5 + extra) / 6
    m = np.einsum("r,rpc->pc", counts, means) / counts.sum()
    v = np.einsum("r,rpc->pc", counts, (means - m) ** 2) / (3 * counts.sum())
    assert np.allclose(est.combined, m, rtol=1e-6)
    assert np.allclose(est.variance, v, rtol=1e-4)


def poisoned_handle_emission(i, row, depth, x, sc, paths, mis, max_bounces):
    """handle_emission, then NaN in the first path's radiance (compiled into a one-off
    kernel: its globals are integrator.py's)."""
    original_handle_emission(i, row, depth, x, sc, paths, mis, max_bounces)  # noqa: F821
    if i == 0:
        paths.radiance[row, 0] = np.nan
        if DEBUG:  # noqa: F821
            _debug_mark(paths, row, 5, paths.radiance[row, 0], 0.0, 0.0)  # noqa: F821


def test_non_finite_samples_are_rejected_and_reported(cbspheres, monkeypatch):
    """A NaN produced by a stage is not written: it is left out and traced to the stage."""
    from engine import integrator, kernels

    def build(constants, compile_with):
        k = kernels.Kernel(constants, cache=False, overrides=dict(
            handle_emission=poisoned_handle_emission,
            original_handle_emission=integrator.handle_emission))
        compile_with(k)
        return k

    monkeypatch.setattr(kernels, "build_now", build)
    monkeypatch.setattr(kernels, "ready_kernel", lambda constants: None)
    r = render(cbspheres, scenes.settings(width=16, height=12, samples=2, threads=1,
                                          kernel="specialised"))
    assert np.isfinite(r.combined).all()
    assert any("stage 'handle emission'" in w and "pixel (x=" in w for w in r.warnings), \
        r.warnings


def test_large_image_memory_is_bounded():
    """A 3840x2160 render keeps its working set in chunks: the film's own arrays plus
    a chunk's rays. We check the film footprint stays far below 2 GB."""
    film = Film(3840, 2160)
    nbytes = sum(a.nbytes for a in film.__dict__.values() if isinstance(a, np.ndarray))
    assert nbytes < 1.0e9


def test_4k_render_peak_memory_under_2gb(tmp_path):
    """A 3840x2160 render at 1 sample, in its own process: peak RSS under 2 GB."""
    import subprocess
    import sys

    code = (
        "import numpy as np\n"
        "from tests.memory import peak_rss_mb\n"
        "from engine import render, World\n"
        "from tests import scenes\n"
        "sc = scenes.cornell_box().build(scenes.cornell_camera(), World())\n"
        "r = render(sc, scenes.settings(width=3840, height=2160, samples=1, max_bounces=2))\n"
        "assert np.isfinite(r.combined).all()\n"
        "print(peak_rss_mb())\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                         cwd=str(__import__("pathlib").Path(__file__).parents[2]))
    peak_mb = float(out.stdout.strip().splitlines()[-1])
    assert peak_mb * 2**20 < 2e9, f"peak RSS {peak_mb * 2**20 / 1e9:.2f} GB"


def test_regions_stitch_into_the_whole_frame(cbspheres):
    """Render borders (region) sample exactly as the whole frame does: four quadrants
    rendered separately stitch into the identical image."""
    st = dict(width=40, height=30, samples=2)
    whole = render(cbspheres, scenes.settings(**st)).combined
    stitched = np.zeros_like(whole)
    for x0, y0, x1, y1 in ((0, 0, 17, 13), (17, 0, 40, 13), (0, 13, 17, 30), (17, 13, 40, 30)):
        part = render(cbspheres, scenes.settings(region=(x0, y0, x1, y1), **st))
        assert part.combined.shape == (y1 - y0, x1 - x0, 4)
        stitched[y0:y1, x0:x1] = part.combined
    assert np.array_equal(stitched, whole)


def test_invalid_region_is_refused():
    with pytest.raises(ValueError, match="region"):
        render(scenes.cbspheres(), scenes.settings(width=10, height=10, region=(5, 0, 20, 10)))


def test_warm_up_compiles_the_generic_kernel_cold_only_when_asked(monkeypatch):
    """A background Blender's warm-up (compile_cold=False) loads the generic kernel only
    where numba's cache has it: on a fresh cache it renders nothing, so the render that
    follows is not kept waiting for numba's compiler. The interface's warm-up compiles it."""
    import threading

    from engine import kernels, renderer

    for thread in threading.enumerate():  # the add-on's own warm-up, where it registered
        if thread.name == "specula-warm-up":
            thread.join()
    rendered = []
    monkeypatch.setattr(renderer, "render", lambda scene, settings: rendered.append(settings))
    monkeypatch.setattr(renderer, "prune_caches", lambda: [])
    monkeypatch.setattr(kernels, "ready_kernel", lambda constants: None)
    monkeypatch.setattr(kernels.Kernel, "on_disk", lambda self: False)
    assert renderer.warm_up(compile_cold=False) is False
    assert rendered == []
    assert renderer.warm_up() is True  # the interface: compiled (here, a stand-in render)
    assert [s.kernel for s in rendered] == ["generic"]
    monkeypatch.setattr(kernels.Kernel, "on_disk", lambda self: True)
    assert renderer.warm_up(compile_cold=False) is True  # cached: loaded
    assert len(rendered) == 2


def test_a_render_says_what_it_waits_for(monkeypatch):
    """on_status hears the BVH being built, then (kernels.build_status) nothing for a
    loaded kernel, "Loading" for one in numba's cache, "Compiling" for one never compiled,
    and that it waits behind another compile under way on another thread (numba compiles
    one function at a time); build_now marks a cold compile while it runs."""
    from engine import Camera, Material, RenderSettings, SceneBuilder, World, kernels

    said = []
    b = SceneBuilder()
    m = b.add_material(Material.diffuse("lamp", (0.5, 0.5, 0.5), emission=(1, 1, 1)))
    b.add_mesh("tri", np.array([[-1.0, -1, -2], [1, -1, -2], [0, 1, -2]]),
               np.array([[0, 1, 2]]), m)
    render(b.build(Camera(), World((0.1, 0.1, 0.1))),
           RenderSettings(width=4, height=3, samples=1, threads=1), on_status=said.append)
    assert said[0] == "Building the ray acceleration structure (1 triangles)", said
    constants = kernels.generic_constants()
    monkeypatch.setattr(kernels, "ready_kernel", lambda constants: None)  # not loaded
    monkeypatch.setattr(kernels.Kernel, "on_disk", lambda self: True)
    assert kernels.build_status(constants) == "Loading the render kernel"
    monkeypatch.setattr(kernels.Kernel, "on_disk", lambda self: False)
    assert kernels.build_status(constants).startswith("Compiling the render kernel")
    seen = []

    def compile_with(kernel):
        other = {**constants, kernels.PLAN_CONSTANTS[0]: not constants[
            kernels.PLAN_CONSTANTS[0]]}
        seen.append(kernels.build_status(other))
        raise RuntimeError("stop here")

    with pytest.raises(RuntimeError):
        kernels.build_now(constants, compile_with)
    assert seen[0].endswith(", after another compiling in the background"), seen
    assert kernels._compiling == set()  # unmarked when the compile ends, even failing
