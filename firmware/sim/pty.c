/*
 * pty.c - the port the host opens: a pseudo-terminal per plug-in (a new one
 * after every replug), the host opening and closing it (auto-reset on open),
 * reading it with back-pressure, and the cable (unplug/replug).
 */
#include "harness.h"

#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <termios.h>
#include <unistd.h>

#include "circuit.h"
#include "pacing.h"
#include "pty.h"
#include "trace.h"
#include "wire.h"

static int master_fd = -1;
static char pty_name[128];
static int plugged = 1;  /* cable in: AVR powered, pty exists */
static int slave_open;  /* host holds the port open */
static uint64_t last_hup_check_ns;
static int holding_reset;  /* DTR auto-reset: held in reset until hold_until_ns */
static uint64_t hold_until_ns;
static unsigned long open_count;
static unsigned long host_rx_stalls;  /* times the harness stopped reading the pty (queue full) */
static int host_rx_stalled;
static unsigned long baud_mismatch_bytes;
static int baud_mismatch_logged;

/* ------------------------------------------------------------------ baud rates */
/* A real Uno's USB bridge runs its UART at the rate the host sets on the port
 * (CDC SET_LINE_CODING, i.e. pyserial's baudrate), so a host at another rate
 * than the firmware's UART garbles every byte both ways.  A pty carries the
 * host's termios speed (the master reads the slave's settings); it is compared
 * with the rate the AVR's UART is set to now (UBRR0 and U2X0: a bootloader and
 * the application may use different rates) within 5 %, a UART's tolerance
 * (115200 against the AVR's 117,647 is 2.1 %).  A mismatch loses the bytes both
 * ways, counted in status.baud_mismatch_bytes and logged once per open, so a
 * program that opens a virtual Uno at the wrong rate fails as on a real one. */
#define UBRR0L_ADDR 0xC4
#define UBRR0H_ADDR 0xC5
#define UCSR0A_ADDR 0xC0
#define U2X0_BIT 0x02
#define TXEN0_BIT 0x08

static unsigned host_baud(void)
{
	static const struct { speed_t code; unsigned baud; } rates[] = {
		{B1200, 1200}, {B2400, 2400}, {B4800, 4800}, {B9600, 9600},
		{B19200, 19200}, {B38400, 38400}, {B57600, 57600}, {B115200, 115200},
		{B230400, 230400}, {B460800, 460800}, {B500000, 500000},
		{B576000, 576000}, {B921600, 921600}, {B1000000, 1000000},
		{B1152000, 1152000}, {B1500000, 1500000}, {B2000000, 2000000},
		{B2500000, 2500000}, {B3000000, 3000000},
	};
	struct termios tio;
	if (master_fd < 0 || tcgetattr(master_fd, &tio) != 0)
		return 0;
	speed_t code = cfgetospeed(&tio);
	for (size_t i = 0; i < sizeof(rates) / sizeof(rates[0]); i++)
		if (rates[i].code == code)
			return rates[i].baud;
	return 0; /* a rate this table does not know: not judged */
}

static unsigned avr_uart_baud(void)
{
	if (!(avr->data[UCSR0B_ADDR] & (RXEN0_BIT | TXEN0_BIT)))
		return 0; /* UART off: the UART model loses the bytes anyway */
	unsigned ubrr = ((unsigned)(avr->data[UBRR0H_ADDR] & 0x0F) << 8) | avr->data[UBRR0L_ADDR];
	unsigned divisor = (avr->data[UCSR0A_ADDR] & U2X0_BIT) ? 8u : 16u;
	return (unsigned)(F_CPU / ((uint64_t)divisor * (ubrr + 1)));
}

/* Whether ``n`` bytes must be lost because the host's rate is not the UART's. */
int baud_mismatch(size_t n)
{
	unsigned host = host_baud(), board = avr_uart_baud();
	if (!host || !board)
		return 0;
	double ratio = (double)host / (double)board;
	if (ratio > 0.95 && ratio < 1.05)
		return 0;
	baud_mismatch_bytes += (unsigned long)n;
	if (!baud_mismatch_logged) {
		baud_mismatch_logged = 1;
		logf_("the host opened the port at %u baud but the firmware's UART runs at %u: "
		      "bytes are lost both ways, as on a real Uno", host, board);
	}
	return 1;
}

int open_pty(void)
{
	int fd = posix_openpt(O_RDWR | O_NOCTTY);
	if (fd < 0 || grantpt(fd) < 0 || unlockpt(fd) < 0) {
		logf_("cannot create pseudo-terminal: %s", strerror(errno));
		if (fd >= 0) close(fd);
		return -1;
	}
	const char *name = ptsname(fd);
	snprintf(pty_name, sizeof(pty_name), "%s", name ? name : "");
	struct termios tio;
	if (tcgetattr(fd, &tio) == 0) {
		cfmakeraw(&tio);
		tcsetattr(fd, TCSANOW, &tio);
	}
	/* Open and close the slave once: configures it raw and makes the master
	 * report POLLHUP until the host opens the port (used to detect the open). */
	int s = open(pty_name, O_RDWR | O_NOCTTY);
	if (s >= 0) {
		if (tcgetattr(s, &tio) == 0) {
			cfmakeraw(&tio);
			tcsetattr(s, TCSANOW, &tio);
		}
		close(s);
	}
	fcntl(fd, F_SETFL, fcntl(fd, F_GETFL) | O_NONBLOCK);
	master_fd = fd;
	slave_open = 0;
	last_hup_check_ns = 0;
	return 0;
}

static void on_slave_open(void)
{
	slave_open = 1;
	open_count++;
	baud_mismatch_logged = 0;
	if (opt->reset_on_open && plugged) {
		reset_held(MCUSR_EXTRF);
		holding_reset = 1;
		hold_until_ns = now_ns() + (uint64_t)opt->boot_delay_ms * 1000000ULL;
	}
}

static void check_slave(void)
{
	if (master_fd < 0 || slave_open)
		return;
	struct pollfd p = {.fd = master_fd, .events = POLLIN};
	if (poll(&p, 1, 0) >= 0 && !(p.revents & POLLHUP))
		on_slave_open();
}

static void read_master(void)
{
	uint8_t buf[512];
	for (;;) {
		size_t want = sizeof(buf);
		if (!holding_reset && plugged) {
			size_t room = host_rx_room();
			if (!room) {
				if (!host_rx_stalled) host_rx_stalls++;
				host_rx_stalled = 1;
				return;
			}
			if (room < want) want = room;
		}
		ssize_t n = read(master_fd, buf, want);
		if (n > 0) {
			if (holding_reset || !plugged) {
				wire_discarded((unsigned long)n);
				continue;
			}
			if (baud_mismatch((size_t)n))
				continue;
			host_rx_stalled = 0;
			trace_event('R', (uint64_t)n);
			host_bytes_in(buf, (size_t)n);
			continue;
		}
		if (n < 0 && (errno == EAGAIN || errno == EINTR))
			return;
		/* EIO (or EOF): the host closed the port */
		slave_open = 0;
		return;
	}
}

/* The pty master's entry in the wait; no POLLIN while host_rx is full (back-pressure). */
int pty_pollfds(struct pollfd *pfds, int n)
{
	if (master_fd >= 0 && slave_open && !holding_reset) {
		pfds[n].fd = master_fd; /* back-pressure: no POLLIN while host_rx is full */
		pfds[n].events = (host_rx_room() ? POLLIN : 0) | (wire_has_output() ? POLLOUT : 0);
		n++;
	} else if (master_fd >= 0 && slave_open) {
		pfds[n].fd = master_fd;  /* still read (and discard) while held in reset */
		pfds[n].events = POLLIN;
		n++;
	}
	return n;
}

int waiting_for_host_open(void)
{
	return master_fd >= 0 && !slave_open;
}

void service_pty(short revents)
{
	if (revents & POLLIN)
		read_master();
	if (revents & (POLLHUP | POLLERR)) {
		if (master_fd >= 0) read_master();
		slave_open = 0;
	}
	if (revents & POLLOUT) output_service(wall_cycles(now_ns()));
}

/* After every wait: has the host opened the port, has the DTR reset ended? */
void pty_housekeeping(uint64_t t)
{
	if (master_fd >= 0 && !slave_open && t - last_hup_check_ns > 2000000ULL) {
		last_hup_check_ns = t;
		check_slave();
	}
	if (holding_reset && t >= hold_until_ns) {
		holding_reset = 0;
		reset_and_run(MCUSR_EXTRF); /* DTR released: an external reset */
	}
}

/* ------------------------------------------------------------------ cable */
void do_unplug(void)
{
	if (!plugged) return;
	flush_out(); /* bytes that already reached the host side go out first */
	plugged = 0;
	holding_reset = 0;
	if (master_fd >= 0) close(master_fd);
	master_fd = -1;
	slave_open = 0;
	wire_unplug();
	stop_pulses();
}

int do_replug(void)
{
	if (plugged) return 0;
	char old_name[sizeof(pty_name)];
	snprintf(old_name, sizeof(old_name), "%s", pty_name);
	if (open_pty() < 0) return -1;
	if (!strcmp(old_name, pty_name)) {
		/* the kernel reused the number: take another one so the host cannot
		 * mistake the new port for the old (a stale path must stay dead) */
		int first = master_fd;
		if (open_pty() < 0) { master_fd = first; snprintf(pty_name, sizeof(pty_name), "%s", old_name); }
		else close(first);
	}
	plugged = 1;
	power_on_reset();
	return 0;
}

/* ------------------------------------------------------------------ state, for the other modules */
int pty_fd(void) { return master_fd; }
const char *pty_port(void) { return pty_name; }
int pty_plugged(void) { return plugged; }
int pty_host_open(void) { return slave_open; }
int pty_holding_reset(void) { return holding_reset; }
uint64_t pty_hold_until(void) { return hold_until_ns; }
void pty_release_reset(void) { holding_reset = 0; }

void pty_status(struct sbuf *r)
{
	sb_add(r, ", \"port\": ");
	sb_json_str(r, plugged ? pty_name : "");
	sb_add(r, ", \"plugged\": %s, \"host_open\": %s, \"opens\": %lu, \"host_rx_stalls\": %lu, "
		  "\"baud_mismatch_bytes\": %lu",
	       plugged ? "true" : "false", slave_open ? "true" : "false", open_count,
	       host_rx_stalls, baud_mismatch_bytes);
}
