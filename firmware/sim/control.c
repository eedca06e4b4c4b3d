/*
 * control.c - the control channel: a Unix stream socket, one JSON object per
 * line each way.  A request names its command in "cmd"; the command table
 * maps the name to its handler and says whether the command only observes.
 * Every other command is a stimulus and first moves the time base to the
 * wall clock (catch_up_wall), so it takes effect at the simulated "now" of
 * its wall time.  The commands and their replies: README.md, "Control channel".
 */
#include "harness.h"
#include "board_map.h"

#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include "avr_eeprom.h"
#include "sim_core.h"
#include "sim_io.h"

#include "bridges.h"
#include "circuit.h"
#include "control.h"
#include "json.h"
#include "pacing.h"
#include "pty.h"
#include "stack.h"
#include "steps.h"
#include "quadrature.h"
#include "spi_device.h"
#include "mpu6050.h"
#include "rcpulse.h"
#include "sonar_model.h"
#include "wire.h"

static char ctl_path[600];

const char *control_path(void) { return ctl_path; }

void control_set_path(const char *path)
{
	snprintf(ctl_path, sizeof(ctl_path), "%s", path); /* too long: setup_control says so */
}
static char ctl_dir[512];
static int listen_fd = -1;
static struct client { int fd; char buf[4096]; size_t len; } clients[MAX_CLIENTS];

/* pin: integer 0..19 or "D0".."D13", "A0".."A5" */
static int get_pin(struct jobj *o, const char *k)
{
	struct jval *v = jget(o, k);
	if (!v) return -1;
	if (v->type == J_NUM) {
		int p = (int)v->num;
		return (p >= 0 && p < NPINS) ? p : -1;
	}
	if (v->type == J_STR) {
		char c = v->str[0];
		int n = atoi(v->str + 1);
		if ((c == 'D' || c == 'd') && n >= 0 && n < 14) return n;
		if ((c == 'A' || c == 'a') && n >= 0 && n < 6) return 14 + n;
	}
	return -1;
}

/* ------------------------------------------------------------------ handlers */
/* Each module reports its own part (pacing, pty, the harness core, wire, bridge
 * models, circuit). */
static void cmd_status(struct jobj *o, struct sbuf *r)
{
	sb_add(r, "{\"ok\": true");
	pacing_status(r);
	pty_status(r);
	harness_status(r);
	wire_status(r);
	bridge_status(r);
	circuit_status(r);
	steps_status(r);
	quadrature_status(r);
	sb_add(r, "}");
}

static void cmd_set_analog(struct jobj *o, struct sbuf *r)
{
	double ch, mv;
	if (!get_num(o, "channel", &ch) || !get_num(o, "mv", &mv) || ch < 0 || ch >= board->adc_channels ||
	    mv < 0 || mv > 5500) {
		sb_add(r, "{\"ok\": false, \"error\": \"set_analog needs channel 0..%d and mv 0..5500\"}",
		       board->adc_channels - 1);
		return;
	}
	circuit_set_analog((int)ch, (int)lround(mv));
	sb_add(r, "{\"ok\": true, \"r2r_override\": %s}",
	       (opt->fixture == FIX_R2R && ch < 6) ? "true" : "false");
}

static void cmd_set_temperature(struct jobj *o, struct sbuf *r)
{
	double x;
	if (!get_num(o, "celsius", &x) || x < -60 || x > 150) {
		sb_add(r, "{\"ok\": false, \"error\": \"set_temperature needs celsius -60..150\"}");
		return;
	}
	circuit_set_temperature(x);
	sb_add(r, "{\"ok\": true, \"mv\": %.1f}", 314.0 + (x - 25.0));
}

static void cmd_drive(struct jobj *o, struct sbuf *r)
{
	int p = get_pin(o, "pin");
	struct jval *lv = jget(o, "level");
	if (p < 2 || !lv || (lv->type != J_NULL && lv->type != J_NUM && lv->type != J_BOOL)) {
		sb_add(r, "{\"ok\": false, \"error\": \"drive needs pin (D2..D13, A0..A5) and level 0|1|null\"}");
		return;
	}
	if (loop_partner(p) >= 0 && lv->type != J_NULL) {
		sb_add(r, "{\"ok\": false, \"error\": \"pin is jumpered in the loopback fixture\"}");
		return;
	}
	circuit_drive(p, lv->type == J_NULL ? -1 : (lv->num != 0));
	sb_add(r, "{\"ok\": true, \"output\": %s}", is_out(p) ? "true" : "false");
}

static void cmd_pin(struct jobj *o, struct sbuf *r)
{
	int p = get_pin(o, "pin");
	if (p < 0) { sb_add(r, "{\"ok\": false, \"error\": \"bad pin\"}"); return; }
	sb_add(r, "{\"ok\": true, \"pin\": %d, \"ddr\": %d, \"port\": %d, \"level\": %d",
	       p, is_out(p), port_bit(p), pin_level(p));
	if (p >= board->first_analog_pin) {
		int ch = p - board->first_analog_pin;
		sb_add(r, ", \"mv\": %d", circuit_adc_mv(ch));
	}
	sb_add(r, "}");
}

static void cmd_pulses(struct jobj *o, struct sbuf *r)
{
	int p = get_pin(o, "pin");
	double cnt, hi, lo;
	if ((p != 2 && p != 3) || !get_num(o, "count", &cnt) || !get_num(o, "high_us", &hi) ||
	    !get_num(o, "low_us", &lo) || cnt < 1 || hi < 1 || lo < 1) {
		sb_add(r, "{\"ok\": false, \"error\": \"pulses needs pin 2|3, count>=1, high_us>=1, low_us>=1\"}");
		return;
	}
	if (!pty_plugged() || is_out(p) || loop_partner(p) >= 0) {
		sb_add(r, "{\"ok\": false, \"error\": \"pin is not a free input (output, jumpered or unplugged)\"}");
		return;
	}
	start_pulses(p, (unsigned long)cnt, (uint64_t)llround(hi * CYC_PER_US),
		     (uint64_t)llround(lo * CYC_PER_US));
	sb_add(r, "{\"ok\": true, \"done_before\": %lu}", pulses_done(p));
}

static void cmd_pulse_stats(struct jobj *o, struct sbuf *r)
{
	int p = get_pin(o, "pin");
	if (p < 0) { sb_add(r, "{\"ok\": false, \"error\": \"bad pin\"}"); return; }
	circuit_pulse_stats(p, r);
}

static void cmd_clear_pulse_stats(struct jobj *o, struct sbuf *r)
{
	int p = get_pin(o, "pin");
	if (p < 0) { sb_add(r, "{\"ok\": false, \"error\": \"bad pin\"}"); return; }
	circuit_clear_pulse_stats(p);
	sb_add(r, "{\"ok\": true}");
}

static void cmd_set_faults(struct jobj *o, struct sbuf *r)
{
	double v, drop, insert, flip;
	wire_faults(&drop, &insert, &flip);
	if (get_num(o, "drop", &v)) drop = v;
	if (get_num(o, "insert", &v)) insert = v;
	if (get_num(o, "flip", &v)) flip = v;
	wire_set_faults(drop, insert, flip);
	if (get_num(o, "seed", &v)) rng_swap((uint64_t)v * 0x9E3779B97F4A7C15ULL + 1);
	sb_add(r, "{\"ok\": true, \"drop\": %g, \"insert\": %g, \"flip\": %g}", drop, insert, flip);
}

static void cmd_unplug(struct jobj *o, struct sbuf *r)
{
	do_unplug();
	sb_add(r, "{\"ok\": true}");
}

static void cmd_replug(struct jobj *o, struct sbuf *r)
{
	if (do_replug() < 0) { sb_add(r, "{\"ok\": false, \"error\": \"cannot create pty\"}"); return; }
	sb_add(r, "{\"ok\": true, \"port\": ");
	sb_json_str(r, pty_port());
	sb_add(r, "}");
}

static void cmd_reset(struct jobj *o, struct sbuf *r)
{
	if (!pty_plugged()) { sb_add(r, "{\"ok\": false, \"error\": \"unplugged\"}"); return; }
	pty_release_reset();
	power_on_reset();
	sb_add(r, "{\"ok\": true}");
}

static void cmd_firmware_cycles(struct jobj *o, struct sbuf *r)
{
	wire_firmware_cycles(r, jget(o, "clear") != NULL);
}

/* {"cmd": "set_latency_timer", "ms": N}: what the host's driver would send an
 * FTDI chip when its latency_timer is written (bridges.c) */
static void cmd_set_latency_timer(struct jobj *o, struct sbuf *r)
{
	double ms;
	if (opt->usb_bridge != BRIDGE_FTDI) {
		sb_add(r, "{\"ok\": false, \"error\": \"set_latency_timer needs --usb-bridge ftdi\"}");
		return;
	}
	if (!get_num(o, "ms", &ms) || ms < 1 || ms > 255 || ms != floor(ms)) {
		sb_add(r, "{\"ok\": false, \"error\": \"set_latency_timer needs ms 1..255\"}");
		return;
	}
	bridge_set_latency_ms((long)ms);
	sb_add(r, "{\"ok\": true, \"latency_ms\": %u}", (unsigned)ms);
}

/* bytes of the I2C EEPROM (size 256) or of the AVR's own EEPROM (1024) */
static void reply_eeprom(struct jobj *o, struct sbuf *r, int size)
{
	double off = 0, len = 16;
	get_num(o, "offset", &off);
	get_num(o, "length", &len);
	if (off < 0 || len < 0 || off + len > size) {
		sb_add(r, "{\"ok\": false, \"error\": \"range outside 0..%d\"}", size);
		return;
	}
	uint8_t buf[1024];
	if (size == 256) {
		memcpy(buf, circuit_i2c_eeprom() + (int)off, (size_t)len);
	} else {
		avr_eeprom_desc_t d = {.ee = buf, .offset = (uint16_t)off, .size = (uint32_t)len};
		/* simavr's eeprom ioctl returns -1 even on success: ignore the result */
		if (len > 0)
			avr_ioctl(avr, AVR_IOCTL_EEPROM_GET, &d);
		if (d.ee != buf) /* some simavr versions return a pointer instead of copying */
			memcpy(buf, d.ee, (size_t)len);
	}
	sb_add(r, "{\"ok\": true, \"offset\": %d, \"bytes\": ", (int)off);
	sb_bytes(r, buf, (int)len);
	sb_add(r, "}");
}

static void cmd_eeprom_i2c(struct jobj *o, struct sbuf *r) { reply_eeprom(o, r, 256); }
static void cmd_eeprom(struct jobj *o, struct sbuf *r) { reply_eeprom(o, r, 1024); }

static void cmd_ping(struct jobj *o, struct sbuf *r) { sb_add(r, "{\"ok\": true}"); }

/* debugging aid: read data-space bytes (registers, I/O, RAM) */
static void cmd_peek(struct jobj *o, struct sbuf *r)
{
	double a = 0, len = 1;
	get_num(o, "addr", &a);
	get_num(o, "length", &len);
	if (a < 0 || len < 1 || a + len > avr->ramend + 1) { sb_add(r, "{\"ok\": false, \"error\": \"bad range\"}"); return; }
	sb_add(r, "{\"ok\": true, \"bytes\": ");
	sb_bytes(r, avr->data + (int)a, (int)len);
	sb_add(r, "}");
}

/* ------------------------------------------------------------------ dispatch */
struct command {
	const char *name;
	int observes; /* reads state only: leaves the time base alone */
	void (*handle)(struct jobj *o, struct sbuf *r);
};

static const struct command commands[] = {
	{"status", 1, cmd_status},
	{"set_analog", 0, cmd_set_analog},
	{"set_temperature", 0, cmd_set_temperature},
	{"drive", 0, cmd_drive},
	{"pin", 1, cmd_pin},
	{"pulses", 0, cmd_pulses},
	{"pulse_stats", 1, cmd_pulse_stats},
	{"clear_pulse_stats", 0, cmd_clear_pulse_stats},
	{"set_faults", 0, cmd_set_faults},
	{"unplug", 0, cmd_unplug},
	{"replug", 0, cmd_replug},
	{"reset", 0, cmd_reset},
	{"firmware_cycles", 1, cmd_firmware_cycles},
	{"eeprom_i2c", 1, cmd_eeprom_i2c},
	{"eeprom", 1, cmd_eeprom},
	{"ping", 1, cmd_ping},
	{"peek", 1, cmd_peek},
	{"quadrature", 0, cmd_quadrature},
	{"quadrature_status", 1, cmd_quadrature_status},
	{"quadrature_stop", 0, cmd_quadrature_stop},
	{"spi_device", 0, cmd_spi_device},
	{"spi_device_status", 1, cmd_spi_device_status},
	{"rcpulse", 0, cmd_rcpulse},
	{"rcpulse_status", 1, cmd_rcpulse_status},
	{"rcpulse_stop", 0, cmd_rcpulse_stop},
	{"sonar", 0, cmd_sonar},
	{"sonar_status", 1, cmd_sonar_status},
	{"set_latency_timer", 0, cmd_set_latency_timer},
	{"step_log", 0, cmd_step_log},
	{"steps", 1, cmd_steps},
	{"limit_at", 0, cmd_limit_at},
	{"stack_paint", 1, cmd_stack_paint},
	{"stack_low", 1, cmd_stack_low},
	{"imu", 0, cmd_imu},
	{"imu_reads", 1, cmd_imu_reads},
};

static const struct command *find_command(const char *name)
{
	for (size_t i = 0; i < sizeof(commands) / sizeof(commands[0]); i++)
		if (!strcmp(name, commands[i].name))
			return &commands[i];
	return NULL;
}

static void handle_command(struct jobj *o, struct sbuf *r)
{
	struct jval *cv = jget(o, "cmd");
	if (!cv) cv = jget(o, "command");
	if (!cv || cv->type != J_STR) { sb_add(r, "{\"ok\": false, \"error\": \"missing cmd\"}"); return; }
	const char *cmd = cv->str;
	const struct command *command = find_command(cmd);
	if (!command || !command->observes)
		catch_up_wall(); /* a stimulus takes effect at the simulated "now" of its wall time */
	if (command) {
		command->handle(o, r);
		return;
	}
	sb_add(r, "{\"ok\": false, \"error\": \"unknown cmd: ");
	for (const char *s = cmd; *s; s++) if (*s != '"' && *s != '\\' && (unsigned char)*s >= 0x20) sb_add(r, "%c", *s);
	sb_add(r, "\"}");
}

/* ------------------------------------------------------------------ clients */
static void client_close(struct client *c)
{
	close(c->fd);
	c->fd = -1;
	c->len = 0;
}

static void client_read(struct client *c)
{
	ssize_t n = read(c->fd, c->buf + c->len, sizeof(c->buf) - 1 - c->len);
	if (n <= 0) {
		if (n < 0 && (errno == EAGAIN || errno == EINTR)) return;
		client_close(c);
		return;
	}
	c->len += (size_t)n;
	for (;;) {
		char *nl = memchr(c->buf, '\n', c->len);
		if (!nl) {
			if (c->len >= sizeof(c->buf) - 1) client_close(c); /* line too long */
			return;
		}
		*nl = 0;
		struct sbuf r = {.d = malloc(1024), .len = 0, .cap = 1024};
		struct jobj o;
		if (parse_json(c->buf, &o) < 0)
			sb_add(&r, "{\"ok\": false, \"error\": \"bad JSON object\"}");
		else
			handle_command(&o, &r);
		sb_add(&r, "\n");
		/* replies are small; a blocking write keeps the protocol simple */
		int fl = fcntl(c->fd, F_GETFL);
		fcntl(c->fd, F_SETFL, fl & ~O_NONBLOCK);
		size_t off = 0;
		while (off < r.len) {
			ssize_t w = send(c->fd, r.d + off, r.len - off, MSG_NOSIGNAL);
			if (w <= 0) break;
			off += (size_t)w;
		}
		fcntl(c->fd, F_SETFL, fl);
		free(r.d);
		size_t used = (size_t)(nl - c->buf) + 1;
		memmove(c->buf, c->buf + used, c->len - used);
		c->len -= used;
		if (off < r.len) { client_close(c); return; }
		run_events(); /* commands may change timing state */
	}
}

int control_pollfds(struct pollfd *pfds, int n)
{
	if (listen_fd >= 0) {
		pfds[n].fd = listen_fd;
		pfds[n].events = POLLIN;
		n++;
	}
	for (int i = 0; i < MAX_CLIENTS; i++)
		if (clients[i].fd >= 0) {
			pfds[n].fd = clients[i].fd;
			pfds[n].events = POLLIN;
			n++;
		}
	return n;
}

void service_control(int fd)
{
	if (fd == listen_fd) {
		int c = accept4(listen_fd, NULL, NULL, SOCK_NONBLOCK | SOCK_CLOEXEC);
		if (c >= 0) {
			int placed = 0;
			for (int k = 0; k < MAX_CLIENTS; k++)
				if (clients[k].fd < 0) { clients[k].fd = c; clients[k].len = 0; placed = 1; break; }
			if (!placed) close(c);
		}
	} else {
		for (int k = 0; k < MAX_CLIENTS; k++)
			if (clients[k].fd == fd) { client_read(&clients[k]); break; }
	}
}

int setup_control(void)
{
	for (int i = 0; i < MAX_CLIENTS; i++) clients[i].fd = -1;
	if (!ctl_path[0]) {
		const char *tmp = getenv("TMPDIR");
		snprintf(ctl_dir, sizeof(ctl_dir), "%s/virtual-uno-XXXXXX", tmp && *tmp ? tmp : "/tmp");
		if (!mkdtemp(ctl_dir)) { logf_("mkdtemp: %s", strerror(errno)); return -1; }
		snprintf(ctl_path, sizeof(ctl_path), "%s/ctl.sock", ctl_dir);
	}
	struct sockaddr_un sa = {.sun_family = AF_UNIX};
	if (strlen(ctl_path) >= sizeof(sa.sun_path)) { logf_("control path too long"); return -1; }
	strcpy(sa.sun_path, ctl_path);
	unlink(ctl_path);
	listen_fd = socket(AF_UNIX, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
	if (listen_fd < 0 || bind(listen_fd, (struct sockaddr *)&sa, sizeof(sa)) < 0 || listen(listen_fd, 8) < 0) {
		logf_("control socket %s: %s", ctl_path, strerror(errno));
		return -1;
	}
	return 0;
}

/* At exit: the socket file and its temporary directory go. */
void close_control(void)
{
	for (int i = 0; i < MAX_CLIENTS; i++)
		if (clients[i].fd >= 0) close(clients[i].fd);
	if (listen_fd >= 0) close(listen_fd);
	unlink(ctl_path);
	if (ctl_dir[0]) rmdir(ctl_dir);
}
