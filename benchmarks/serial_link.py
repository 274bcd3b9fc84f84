"""Robot-link benchmark: decoder throughput, CRC speed, and end-to-end latency over a real pty.

    python benchmarks/serial_link.py [--seconds 3] [--rates 50 500]

Prints frames/s decoded (clean stream, and with garbage plus bit errors), the CRC-16
against the C implementation in ``binascii``, and the latency from the virtual MCU latching
a reading to the odometry grabber publishing the pose (host and MCU share one clock).
"""

from __future__ import annotations

import argparse
import binascii
import resource
import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from app.grabbers.odometry_grabber import OdometryGrabber
from app.robot_link.protocol import EncoderFrame, FrameDecoder, crc16, encode
from app.robot_link.virtual_mcu import LineFaults, VirtualMCU

N_FRAMES = 50_000
CHUNK = 256  # bytes per feed(), about what one pyserial read returns under load


def make_stream(n: int) -> bytes:
    return b"".join(encode(EncoderFrame(i % 65536, 20_000 * i % 2**32, 3 * i, 4 * i)) for i in range(n))


def decode_rate(stream: bytes) -> tuple[float, FrameDecoder]:
    decoder = FrameDecoder()
    t0 = time.perf_counter()
    for i in range(0, len(stream), CHUNK):
        decoder.feed(stream[i : i + CHUNK])
    return decoder.stats.frames / (time.perf_counter() - t0), decoder


def bench_decoder(rng: np.random.Generator) -> None:
    clean = make_stream(N_FRAMES)
    rate, _ = decode_rate(clean)
    print(f"decode clean: {rate:,.0f} frames/s ({rate * 20 / 1e6:.2f} MB/s; {N_FRAMES} frames of 20 B)")
    faults = LineFaults(rng, flip_rate=0.001, garbage_rate=0.2, garbage_max=20)
    dirty = b"".join(faults.apply(clean[i : i + 20]) for i in range(0, len(clean), 20))
    rate, dec = decode_rate(dirty)
    rejected = sum(dec.stats.rejected.values())
    print(
        f"decode with garbage (+{len(dirty) / len(clean) - 1:.0%} bytes) and bit errors: {rate:,.0f} frames/s"
        f" ({dec.stats.frames} ok, {rejected} rejected, {dec.stats.bytes_skipped} bytes skipped)"
    )
    body = clean[2:18]
    n = 100_000
    t0 = time.perf_counter()
    for _ in range(n):
        crc16(body)
    ours = (time.perf_counter() - t0) / n
    t0 = time.perf_counter()
    for _ in range(n):
        binascii.crc_hqx(body, 0xFFFF)
    theirs = (time.perf_counter() - t0) / n
    print(f"crc16 of a 16-byte frame body: {ours * 1e6:.2f} us (binascii.crc_hqx: {theirs * 1e6:.2f} us)")


class SteadyArc:
    """Wheels turning at a constant rate on the wall clock (the benchmark's stand-in simulator)."""

    def __init__(self) -> None:
        self.t0 = time.monotonic()

    def ticks(self) -> tuple[int, int]:
        t = time.monotonic() - self.t0
        return int(1000 * t), int(1300 * t)

    def set_velocity(self, v: float, w: float) -> None:
        pass


def bench_latency(rate_hz: float, seconds: float) -> None:
    wheels = SteadyArc()
    with (
        VirtualMCU(wheels, rate_hz=rate_hz, clock=time.monotonic) as mcu,
        OdometryGrabber(mcu.path, clock=time.monotonic) as grabber,
    ):
        grabber.wait_connected(5.0)
        latencies = []
        seq = grabber.odometry.get()[0]
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            got = grabber.odometry.wait_newer(seq, 1.0)
            if got is None:
                continue
            seq, odo = got
            latencies.append(((odo.stamp * 1e6 - odo.mcu_us) % 2**32) * 1e-6)
        stats = grabber.stats()
        sent = mcu.stats.frames_sent
    ms = np.array(latencies) * 1e3
    print(
        f"pty end-to-end at {rate_hz:g} Hz: {len(ms)} poses seen of {sent} frames sent, latency median "
        f"{statistics.median(ms):.3f} ms, p95 {np.percentile(ms, 95):.3f} ms, max {ms.max():.3f} ms; "
        f"{stats.frames_ok} frames ok, rejects {sum(stats.rejected.values())}, "
        f"odometry jumps rejected {stats.odometry_jumps_rejected}"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=3.0, help="latency measurement per rate")
    parser.add_argument("--rates", type=float, nargs="+", default=[50.0, 500.0], help="MCU frame rates, Hz")
    args = parser.parse_args()
    rng = np.random.default_rng(1)
    bench_decoder(rng)
    for rate in args.rates:
        bench_latency(rate, args.seconds)
    print(f"peak RSS: {resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.0f} MiB")


if __name__ == "__main__":
    main()
