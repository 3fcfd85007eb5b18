"""``python -m cepam_gym.precompile`` (run by ``make install``) drives every kernel it names and
says how long each took; a second run finds them in numba's cache."""

from __future__ import annotations


def test_precompile_drives_the_recommended_ids_kernels(capsys):
    from cepam_gym import versions
    from cepam_gym.precompile import main

    assert main() == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[-1].startswith("precompile: the kernels are in numba's cache")
    stages = [line for line in lines[:-1] if line.startswith("precompile: ")]
    assert len(stages) == 10 and all(line.endswith(" s") for line in stages)
    rig = versions.RECOMMENDED_ID
    for what in ("(batched)", "(batched, parallel)", "(single)"):
        assert any(f"{rig} {what}" in line for line in stages), what
    for name in ("baseline", "mpc", "adaptive_mpc", "oracle"):
        assert any(f"{name} on {rig}" in line for line in stages), name
