"""The rig protocol's packets, the UDP transport on the loopback, and the envs' observation of a
rig's readings (the same kernel as the env's)."""

from __future__ import annotations

import socket
import time

import gymnasium as gym
import numpy as np
import pytest

from cepam_gym import plant as pl
from cepam_gym.envs.model import model_of
from cepam_gym.errors import InputError
from cepam_gym.physics import layout as ix
from cepam_gym.rig import protocol as rp
from cepam_gym.rig.observation import RigObserver
from cepam_gym.rig.udp import UdpRig, parse_address


def test_packets_have_their_documented_sizes_and_round_trip():
    assert rp.SENSOR.size == 36 and rp.COMMAND.size == 16
    r = rp.Reading(1.25, 123456.0, 65432.0, 0.17, 250e3, seq=7, ack_seq=5, flags=rp.FLAG_STOPPED)
    back = rp.unpack_reading(rp.pack_reading(r))
    assert back.seq == 7 and back.ack_seq == 5 and back.stopped and back.time == 1.25
    assert back.pressure_c == pytest.approx(123456.0) and back.length == pytest.approx(0.17, rel=1e-6)
    assert rp.unpack_command(rp.pack_command(rp.KIND_COMMAND, 9, 0.5, -0.25)) == (2, 0, 9, 0.5, -0.25)
    # little-endian, as documented: the magic's low byte first
    assert rp.pack_command(rp.KIND_STOP, 1)[:3] == bytes([0x5A, 0xCE, rp.KIND_STOP])
    with pytest.raises(rp.PacketError, match="bytes"):
        rp.unpack_reading(b"\0" * 35)
    with pytest.raises(rp.PacketError, match="magic"):
        rp.unpack_command(b"\0" * 16)


@pytest.mark.parametrize("text", ["localhost", "127.0.0.1:0", "h:99999", ":80", "h:port"])
def test_a_bad_rig_address_is_named(text):
    with pytest.raises(InputError, match="host:port"):
        parse_address(text)


def test_the_udp_rig_reads_the_newest_reading_and_sends_commands():
    peer = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    peer.bind(("127.0.0.1", 0))
    rig = UdpRig(("127.0.0.1", peer.getsockname()[1]))
    try:
        rig.write(0.5, -0.5)
        data, host = peer.recvfrom(64)
        assert rp.unpack_command(data)[3:] == (0.5, -0.5)
        for seq in (3, 1, 2):  # the newest by number wins; older ones arriving late are dropped
            peer.sendto(rp.pack_reading(rp.Reading(seq * 0.01, 1e3, 2e3, 0.16, 2e5, seq=seq)), host)
        peer.sendto(b"junk", host)
        time.sleep(0.05)
        r = rig.read()
        assert r is not None and r.seq == 3 and rig.bad_packets == 1
        assert rig.read() is None
        rig.stop()  # one packet: the stop protocol repeats it (cepam_gym.rig.stop)
        assert rp.unpack_command(peer.recvfrom(64)[0])[0] == rp.KIND_STOP
        # the packet numbers wrap around (newer), and a rig that restarts counts from 1 again
        for seq in (2**31, 2**32 - 1, 2, 5000, 1):
            peer.sendto(rp.pack_reading(rp.Reading(seq * 1e-9, 1e3, 2e3, 0.16, 2e5, seq=seq)), host)
            time.sleep(0.02)
            assert (r := rig.read()) is not None and r.seq == seq
        assert rig.restarts == 1
    finally:
        rig.close()
        peer.close()


def test_packet_numbers_compare_modulo_two_to_the_32():
    assert rp.seq_newer(5, 4) and not rp.seq_newer(4, 5) and not rp.seq_newer(4, 4)
    assert rp.seq_newer(3, 2**32 - 2)  # across the wrap-around
    assert not rp.seq_restarted(4, 5)  # a late datagram
    assert rp.seq_restarted(1, 50_000) and not rp.seq_restarted(50_001, 50_000)


def test_the_observer_builds_the_envs_observation_with_its_own_kernel():
    env = gym.make("cepam_gym/CEPAM-v2")
    obs, _ = env.reset(seed=4)
    m = model_of(env)
    obs_rig = RigObserver(m, m.target_l[0].copy(), m.target_k[0].copy())
    rng = np.random.default_rng(0)
    checked = 0
    prev = np.zeros(2)
    for k in range(40):
        x, aux, p = m.state[0], m.aux[0], m.params[0]
        reading = rp.Reading(
            k * m.control_dt, aux[pl.A_PC], aux[pl.A_PE], x[pl.S_L], p[ix.P_SUP] - p[ix.P_ATM]
        )
        got = obs_rig.observe(reading, int(m.t_idx[0]), prev, velocity=x[pl.S_V])
        np.testing.assert_allclose(got, obs, atol=1e-6, err_msg=f"step {k}")
        checked += 1
        prev = rng.uniform(-1, 1, 2).astype(np.float32)  # inside [-1, 1]: applied as it is
        obs, *_ = env.step(prev)
    assert checked == 40
    # the preview columns follow the step: another step's targets give another observation
    assert not np.allclose(obs_rig.observe(reading, 300, prev, velocity=0.0), got)


def test_the_velocity_estimate_follows_a_ramp():
    env = gym.make("cepam_gym/CEPAM-v2")
    env.reset(seed=0)
    m = model_of(env)
    o = RigObserver(m, np.full(10, 0.17), np.full(10, 1000.0), velocity_filter_s=0.01)
    for k in range(50):  # 5 cm/s
        v = o.velocity(rp.Reading(k * 0.002, 0.0, 0.0, 0.16 + 0.05 * k * 0.002, 2e5))
    assert v == pytest.approx(0.05, rel=1e-3)


def test_the_observer_refuses_references_that_are_not_one_per_step():
    env = gym.make("cepam_gym/CEPAM-v2")
    env.reset(seed=0)
    with pytest.raises(InputError, match="references"):
        RigObserver(model_of(env), np.zeros(5), np.zeros(4))
