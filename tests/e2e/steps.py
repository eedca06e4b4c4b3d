"""The virtual Uno's step logs (firmware/sim/steps.c): every step pulse with its time."""

from __future__ import annotations

import anyio

from arduinoio_async.sim import VirtualUno


async def step_log(uno: VirtualUno, *pins: str) -> None:
    """Start (clear) logging the rising edges of ``pins``."""
    for pin in pins:
        await uno.command("step_log", pin=pin, enable=True)


async def step_times(uno: VirtualUno, pin: str) -> tuple[list[float], float | None]:
    """Every logged step time of ``pin`` (simulated us) and when its limit_at fired."""
    times: list[float] = []
    while True:
        reply = await uno.command("steps", pin=pin, **{"from": len(times)})
        times += reply["times_us"]
        if len(times) >= reply["count"]:
            return times, reply["limit_us"]


async def step_count(uno: VirtualUno, pin: str) -> int:
    reply = await uno.command("steps", pin=pin, **{"from": 1 << 30})
    return int(reply["count"])


async def quiet_steps(uno: VirtualUno, pin: str, quiet_us: float, within: float = 10.0) -> int:
    """The step count once ``pin`` took no step for ``quiet_us`` of simulated time."""
    with anyio.fail_after(within):
        while True:
            count = await step_count(uno, pin)
            start = float((await uno.status())["sim_us"])
            while float((await uno.status())["sim_us"]) < start + quiet_us:  # noqa: ASYNC110
                await anyio.sleep(0.005)  # simulated time, polled
            if await step_count(uno, pin) == count:
                return count


def fit_quadratic(ts: list[float], ns: list[float]) -> tuple[float, float, float]:
    """Least squares n = c0 + c1 t + c2 t^2 (t in s); returns (c0, c1, c2)."""
    t0 = ts[0]
    xs = [t - t0 for t in ts]
    s = [sum(x**k for x in xs) for k in range(5)]
    b = [sum(n * x**k for x, n in zip(xs, ns, strict=True)) for k in range(3)]
    m = [[s[0], s[1], s[2]], [s[1], s[2], s[3]], [s[2], s[3], s[4]]]

    def det(a: list[list[float]]) -> float:
        return (
            a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1])
            - a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0])
            + a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0])
        )

    d = det(m)
    out = []
    for col in range(3):
        mc = [row[:] for row in m]
        for r in range(3):
            mc[r][col] = b[r]
        out.append(det(mc) / d)
    return out[0], out[1], out[2]
