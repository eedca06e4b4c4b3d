"""A web API that owns the robot's boards: FastAPI with a BoardManager in its lifespan.

    pip install "arduinoio_async" fastapi uvicorn
    ARDUINOIO_PORTS=/dev/ttyACM0 uvicorn --app-dir examples fastapi_app:app
    curl -X PUT 'localhost:8000/boards/1/gpio/D13?level=true'

The manager lives exactly as long as the app (FastAPI's lifespan), finds boards by ID on
the ports of ``ARDUINOIO_PORTS`` (and USB serial devices), and the library's exceptions
map onto HTTP statuses: an unknown board is 404, a bad pin or value 422, a board that
went away mid-request 503.
"""

from __future__ import annotations

from collections.abc import AsyncIterator
from contextlib import asynccontextmanager

from fastapi import FastAPI, HTTPException, Request
from fastapi.responses import JSONResponse

from arduinoio_async import (
    AnalogPin,
    Board,
    BoardManager,
    BoardNotFoundError,
    DigitalPin,
    LinkError,
    UsageError,
)


@asynccontextmanager
async def lifespan(app: FastAPI) -> AsyncIterator[None]:
    async with BoardManager() as boards:
        app.state.boards = boards
        yield


app = FastAPI(title="robot boards", lifespan=lifespan)


async def board_of(request: Request, board_id: int) -> Board:
    boards: BoardManager = request.app.state.boards
    return await boards.get(board_id, timeout=1.0)


def pin_named(name: str, kind: type[DigitalPin] | type[AnalogPin]) -> DigitalPin | AnalogPin:
    try:
        return kind[name.upper()]
    except KeyError:
        raise HTTPException(422, f"no pin {name!r}") from None


@app.exception_handler(BoardNotFoundError)
async def not_found(request: Request, exc: BoardNotFoundError) -> JSONResponse:
    return JSONResponse({"detail": str(exc)}, status_code=404)


@app.exception_handler(UsageError)
async def bad_request(request: Request, exc: UsageError) -> JSONResponse:
    return JSONResponse({"detail": str(exc)}, status_code=422)


@app.exception_handler(LinkError)
async def board_away(request: Request, exc: LinkError) -> JSONResponse:
    return JSONResponse({"detail": str(exc)}, status_code=503)


@app.get("/boards")
async def list_boards(request: Request) -> dict[str, str]:
    boards: BoardManager = request.app.state.boards
    return {f"0x{board_id:04X}": board.port for board_id, board in boards.present().items()}


@app.put("/boards/{board_id}/gpio/{pin}")
async def write_pin(request: Request, board_id: int, pin: str, level: bool) -> dict[str, bool]:
    board = await board_of(request, board_id)
    digital = pin_named(pin, DigitalPin)
    assert isinstance(digital, DigitalPin)
    await board.gpio(digital).write(level)
    return {"level": level}


@app.get("/boards/{board_id}/gpio/{pin}")
async def read_pin(request: Request, board_id: int, pin: str) -> dict[str, bool]:
    board = await board_of(request, board_id)
    digital = pin_named(pin, DigitalPin)
    assert isinstance(digital, DigitalPin)
    state = await board.gpio(digital).read()
    return {"level": state.level, "rose": state.rose, "fell": state.fell}


@app.get("/boards/{board_id}/analog/{pin}")
async def read_volts(request: Request, board_id: int, pin: str) -> dict[str, float]:
    board = await board_of(request, board_id)
    analog = pin_named(pin, AnalogPin)
    assert isinstance(analog, AnalogPin)
    return {"volts": await board.analog(analog).read_volts()}
