"""An IMU streamed by a board served on the network: the I2C block set-ups pass through
the server, the samples reach the client that streams, and another client cannot change
the blocks that client's stream reads."""

from __future__ import annotations

import pytest

from arduinoio_async import A0, I2CBlock, I2CSpeed
from arduinoio_async import protocol as p
from arduinoio_async.board.imu import MPU6050
from arduinoio_async.errors import BoardError
from arduinoio_async.network import RemoteBoards

from .conftest import ServeFactory

pytestmark = pytest.mark.sim


async def test_a_remote_client_streams_the_imu(serve_unos: ServeFactory) -> None:
    async with (
        serve_unos([7], baud=1_000_000, profile="sensing") as served,
        RemoteBoards(connect=[served.endpoint]) as first,
        RemoteBoards(connect=[served.endpoint]) as second,
    ):
        uno = served.unos[7]
        a, b = await first.get(7), await second.get(7)
        imu = MPU6050(await a.i2c(I2CSpeed.KHZ_400))
        await imu.configure(accel_g=2)
        logged = (await uno.command("imu"))["logged"]
        blocks: list[bytes | None] = []
        async with a.stream(analog=[A0], i2c=[imu.block], period_ms=5) as samples:
            async for sample in samples:
                assert sample.i2c is not None
                blocks.append(sample.i2c[0])
                if len(blocks) == 50:
                    break
            with pytest.raises(BoardError) as busy:  # the streaming client's block slot
                await b.request(p.I2CBlock(0, 0x50, 0, 4))
            assert busy.value.code is p.ErrorCode.SLOT_BUSY
            assert "block 0" in str(busy.value)
        reply = await uno.command("imu_reads", **{"from": logged, "count": 50})
        assert blocks == [bytes(data) for _, data in reply["reads"]]
        assert samples.gaps == 0
        assert I2CBlock(0x68, 0x3B, 14) == imu.block
