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

int master_fd = -1;
char pty_name[128];
int plugged = 1;
int slave_open;
static uint64_t last_hup_check_ns;
int holding_reset;
uint64_t hold_until_ns;
unsigned long open_count;
unsigned long host_rx_stalls;
static int host_rx_stalled;

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
	if (opt_reset_on_open && plugged) {
		reset_avr(MCUSR_EXTRF);
		avr->state = cpu_Running;
		reset_count++;
		after_reset();
		holding_reset = 1;
		hold_until_ns = now_ns() + (uint64_t)opt_boot_delay_ms * 1000000ULL;
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
				bytes_discarded += (unsigned long)n;
				continue;
			}
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
