#!/usr/bin/env node
// runner.js - the arduinoio firmware images on a second emulator, avr8js.
//
// Usage: node runner.js --mcu uno|mega2560 --hex FILE
// Loads the Intel HEX, runs it at 16 MHz, serves USART0 on a TCP port of 127.0.0.1
// (the library opens it as socket://127.0.0.1:PORT), wires the loopback fixture
// (jumpers D2-D3, D4-D5, ... up to D13 on the Uno, D15 on the Mega: an output drives its
// partner's input, an input with pull-up pulls an input partner high) and answers JSON
// control lines on stdin with JSON lines on stdout: the first stdout line is
// {"ready": true, "port": N}.  Ground truth comes from here, not from the firmware:
//   {"op": "pin", "pin": 5}                  -> {"ok": true, "ddr": 0|1, "level": 0|1}
//   {"op": "adc", "channel": 0, "mv": 2500}  -> {"ok": true}   (ATmega328P only: see below)
//   {"op": "pulses", "pin": 9}               -> {"ok": true, "rises": n, "last_high_cycles": c}
//   {"op": "cycles"}                         -> {"ok": true, "cycles": n}
// avr8js models USART, GPIO, timers 0-2, ADC, SPI, TWI, watchdog with the ATmega328P's
// interrupt vectors; the Mega's vectors differ, so the USART/timer/ADC configs are rebuilt
// here with the ATmega2560's vector addresses (word addresses = vector number * 2).
'use strict';
const fs = require('fs');
const net = require('net');
const readline = require('readline');
const avr = require('avr8js');

const FREQ = 16e6;

function parseArgs(argv) {
  const out = {};
  for (let i = 2; i < argv.length; i += 2) out[argv[i].replace(/^--/, '')] = argv[i + 1];
  if (!out.mcu || !out.hex) throw new Error('usage: runner.js --mcu uno|mega2560 --hex FILE');
  return out;
}

function loadHex(text, target) {
  let base = 0;
  for (const raw of text.split('\n')) {
    const line = raw.trim();
    if (!line.startsWith(':')) continue;
    const n = parseInt(line.substr(1, 2), 16);
    const addr = parseInt(line.substr(3, 4), 16);
    const type = parseInt(line.substr(7, 2), 16);
    if (type === 0) {
      for (let i = 0; i < n; i++) target[base + addr + i] = parseInt(line.substr(9 + i * 2, 2), 16);
    } else if (type === 2) {
      base = parseInt(line.substr(9, 4), 16) << 4;
    } else if (type === 4) {
      base = parseInt(line.substr(9, 4), 16) << 16;
    }
  }
}

const BOARDS = {
  uno: {
    flash: 0x8000,
    sram: 2048,
    ports: { B: avr.portBConfig, C: avr.portCConfig, D: avr.portDConfig },
    pins: ['D0', 'D1', 'D2', 'D3', 'D4', 'D5', 'D6', 'D7', 'B0', 'B1', 'B2', 'B3', 'B4', 'B5',
      'C0', 'C1', 'C2', 'C3', 'C4', 'C5'],
    lastJumpered: 13,
    usart: avr.usart0Config,
    timers: [avr.timer0Config, avr.timer1Config, avr.timer2Config],
    adc: avr.adcConfig,
  },
  mega2560: {
    flash: 0x40000,
    // data space 0x0000-0x21FF: avr8js adds 0x100 of registers, the Mega has 0x200.
    sram: 0x2200 - 0x100,
    ports: {
      A: avr.portAConfig, B: avr.portBConfig, C: avr.portCConfig, D: avr.portDConfig,
      E: avr.portEConfig, F: avr.portFConfig, G: avr.portGConfig, H: avr.portHConfig,
      J: avr.portJConfig, K: avr.portKConfig, L: avr.portLConfig,
    },
    pins: ['E0', 'E1', 'E4', 'E5', 'G5', 'E3', 'H3', 'H4', 'H5', 'H6', 'B4', 'B5', 'B6', 'B7',
      'J1', 'J0'],
    lastJumpered: 15,
    usart: Object.assign({}, avr.usart0Config,
      { rxCompleteInterrupt: 0x32, dataRegisterEmptyInterrupt: 0x34, txCompleteInterrupt: 0x36 }),
    timers: [
      Object.assign({}, avr.timer0Config, { compAInterrupt: 0x2a, compBInterrupt: 0x2c,
        ovfInterrupt: 0x2e, compPortA: avr.portBConfig.PORT, compPinA: 7,
        compPortB: avr.portGConfig.PORT, compPinB: 5 }),
      Object.assign({}, avr.timer1Config, { captureInterrupt: 0x20, compAInterrupt: 0x22,
        compBInterrupt: 0x24, ovfInterrupt: 0x28, compPortA: avr.portBConfig.PORT, compPinA: 5,
        compPortB: avr.portBConfig.PORT, compPinB: 6 }),
      Object.assign({}, avr.timer2Config, { compAInterrupt: 0x1a, compBInterrupt: 0x1c,
        ovfInterrupt: 0x1e, compPortA: avr.portBConfig.PORT, compPinA: 4,
        compPortB: avr.portHConfig.PORT, compPinB: 6 }),
    ],
    adc: null, // avr8js's ADC has the ATmega328P's 8-channel mux only (no MUX5 / ADC8-15)
  },
};

function main() {
  const args = parseArgs(process.argv);
  const board = BOARDS[args.mcu];
  if (!board) throw new Error(`unknown mcu ${args.mcu}`);
  const flash = new Uint8Array(board.flash);
  loadHex(fs.readFileSync(args.hex, 'utf8'), flash);
  const cpu = new avr.CPU(new Uint16Array(flash.buffer), board.sram);
  const ports = {};
  for (const [name, cfg] of Object.entries(board.ports)) ports[name] = new avr.AVRIOPort(cpu, cfg);
  const usart = new avr.AVRUSART(cpu, board.usart, FREQ);
  // avr8js 0.21 bug: its UCSRnA write hook stores `value & (MPCM | U2X)`, wiping the
  // read-only RXC and UDRE flags, so firmware that writes UCSR0A = U2X0 | TXC0 (to clear
  // TXC before a frame, as firmware/src/uart.c does) never sees UDRE again and never
  // transmits.  The datasheet: RXC/UDRE/FE/DOR/UPE are read-only, TXC is write-1-to-clear.
  // avr8js 0.21 bug 2: its UDRE interrupt is not `constant`, so entering the vector clears
  // UDRE; an ISR that finds nothing to send (it turns UDRIE off, as uart.c's does) leaves
  // UDRE clear for ever.  On the chip UDRE is cleared only by writing UDR.
  usart.UDRE.constant = true;
  const ucsraHook = cpu.writeHooks[board.usart.UCSRA];
  cpu.writeHooks[board.usart.UCSRA] = (value, oldValue, addr, mask) => {
    const readOnly = cpu.data[board.usart.UCSRA] & 0xbc; // RXC, UDRE, FE, DOR, UPE
    const result = ucsraHook(value, oldValue, addr, mask);
    cpu.data[board.usart.UCSRA] |= readOnly;
    return result;
  };
  for (const t of board.timers) new avr.AVRTimer(cpu, t);
  const adc = board.adc ? new avr.AVRADC(cpu, board.adc) : null;
  const clock = new avr.AVRClock(cpu, FREQ, avr.clockConfig);
  new avr.AVRWatchdog(cpu, args.mcu === "mega2560"
    ? Object.assign({}, avr.watchdogConfig, { watchdogInterrupt: 0x18 }) : avr.watchdogConfig, clock);

  const pinRef = (pin) => {
    const spec = board.pins[pin];
    return spec ? { port: ports[spec[0]], bit: Number(spec[1]) } : null;
  };

  // Loopback fixture: D2-D3, D4-D5, ... up to lastJumpered.
  const pairs = [];
  for (let p = 2; p + 1 <= board.lastJumpered; p += 2) pairs.push([pinRef(p), pinRef(p + 1)]);
  const drive = (a, b) => {
    const sa = a.port.pinState(a.bit);
    const sb = b.port.pinState(b.bit);
    const out = (s) => s === avr.PinState.High || s === avr.PinState.Low;
    if (out(sa) && !out(sb)) b.port.setPin(b.bit, sa === avr.PinState.High);
    else if (out(sb) && !out(sa)) a.port.setPin(a.bit, sb === avr.PinState.High);
    else if (!out(sa) && !out(sb)) {
      const up = sa === avr.PinState.InputPullUp || sb === avr.PinState.InputPullUp;
      a.port.setPin(a.bit, up);
      b.port.setPin(b.bit, up);
    }
  };
  const settle = () => { for (const [a, b] of pairs) drive(a, b); };

  // Pulse capture on every pin, at cycle resolution.
  const capture = {};
  for (const [name, port] of Object.entries(ports)) {
    let last = port.pinState ? 0 : 0;
    port.addListener((value) => {
      const changed = value ^ last;
      last = value;
      for (let bit = 0; bit < 8; bit++) {
        if (!(changed & (1 << bit))) continue;
        const key = name + bit;
        const c = capture[key] || (capture[key] = { rises: 0, riseAt: 0, lastHigh: 0 });
        if (value & (1 << bit)) { c.rises++; c.riseAt = cpu.cycles; } else if (c.rises) {
          c.lastHigh = cpu.cycles - c.riseAt;
        }
      }
      settle();
    });
  }

  // USART0 <-> one TCP client.
  const rxQueue = [];
  let client = null;
  const DEBUG = !!process.env.AVR8JS_DEBUG;
  const feed = () => {
    if (DEBUG && rxQueue.length) process.stderr.write(`rx pending ${rxQueue.length} ucsrb=${cpu.data[0xc1].toString(16)} ucsra=${cpu.data[0xc0].toString(16)} sreg=${cpu.data[0x5f].toString(16)} pc=${cpu.pc} cyc=${cpu.cycles}\n`);
    if (rxQueue.length && usart.writeByte(rxQueue[0])) rxQueue.shift();
  };
  // avr8js keeps one received byte (no 2-byte FIFO, no DOR): a byte arriving before the
  // firmware read the last one overwrites it.  So the host's bytes go in at line rate but
  // never before RXC is clear: this runner cannot show receive overruns (simavr can).
  const udrRead = cpu.readHooks[board.usart.UDR];
  cpu.readHooks[board.usart.UDR] = (addr) => {
    const value = udrRead(addr);
    feed();
    return value;
  };
  usart.onByteTransmit = (b) => { if (DEBUG) process.stderr.write(`tx ${b}\n`); if (client) client.write(Buffer.from([b])); };
  const server = net.createServer((sock) => {
    if (client) client.destroy();
    client = sock;
    sock.setNoDelay(true);
    sock.on('data', (d) => {
      for (const b of d) rxQueue.push(b);
      // now, not at the end of the next slice: a frame split over two TCP reads must not
      // sit 10 ms of firmware time in the middle (the firmware times out a partial frame)
      if (!usart.rxBusy && !(cpu.data[board.usart.UCSRA] & 0x80)) feed();
    });
    sock.on('close', () => { if (client === sock) client = null; });
    sock.on('error', () => {});
  });

  const reply = (obj) => process.stdout.write(JSON.stringify(obj) + '\n');
  const rl = readline.createInterface({ input: process.stdin });
  rl.on('line', (line) => {
    let req;
    try { req = JSON.parse(line); } catch (e) { return reply({ ok: false, error: 'not JSON' }); }
    if (req.op === 'pin') {
      const r = pinRef(req.pin);
      if (!r) return reply({ ok: false, error: 'no such pin' });
      const s = r.port.pinState(r.bit);
      const isOut = s === avr.PinState.High || s === avr.PinState.Low;
      const pinReg = cpu.data[r.port.portConfig.PIN];
      return reply({ ok: true, ddr: isOut ? 1 : 0, level: (pinReg >> r.bit) & 1 });
    }
    if (req.op === 'adc') {
      if (!adc) return reply({ ok: false, error: 'avr8js has no ADC model for this MCU' });
      adc.channelValues[req.channel] = req.mv / 1000;
      return reply({ ok: true });
    }
    if (req.op === 'pulses') {
      const spec = board.pins[req.pin];
      const c = (spec && capture[spec]) || { rises: 0, lastHigh: 0 };
      return reply({ ok: true, rises: c.rises, last_high_cycles: c.lastHigh });
    }
    if (req.op === 'cycles') return reply({ ok: true, cycles: cpu.cycles });
    return reply({ ok: false, error: 'unknown op' });
  });
  rl.on('close', () => process.exit(0));

  // Run paced to wall-clock time (never ahead of 16 MHz real time), in slices.
  const t0 = process.hrtime.bigint();
  const slice = () => {
    const elapsed = Number(process.hrtime.bigint() - t0) / 1e9;
    const target = Math.min(elapsed * FREQ, cpu.cycles + 160000);
    while (cpu.cycles < target) {
      avr.avrInstruction(cpu);
      cpu.tick();
    }
    if (!usart.rxBusy && !(cpu.data[board.usart.UCSRA] & 0x80)) feed();
    if (DEBUG && cpu.cycles % 1600000 < 160000) process.stderr.write(`tick ucsrb=${cpu.data[0xc1].toString(16)} ucsra=${cpu.data[0xc0].toString(16)} pc=${cpu.pc} cyc=${cpu.cycles} next=${cpu.nextInterrupt} ie=${JSON.stringify(cpu.pendingInterrupts && cpu.pendingInterrupts.length)}\n`);
    setImmediate(slice);
  };
  server.listen(0, '127.0.0.1', () => {
    reply({ ready: true, port: server.address().port, mcu: args.mcu });
    slice();
  });
}

main();
