/*
 * control.c - the control channel: a Unix stream socket, one JSON object per
 * line each way.  A request names its command in "cmd"; the command table
 * maps the name to its handler and says whether the command only observes.
 * Every other command is a stimulus and first moves the time base to the
 * wall clock (catch_up_wall), so it takes effect at the simulated "now" of
 * its wall time.  The commands and their replies: README.md, "Control channel".
 */
#include "harness.h"

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

#include "circuit.h"
#include "control.h"
#include "json.h"
#include "pacing.h"
#include "pty.h"
#include "quadrature.h"
#include "wire.h"

char ctl_path[600];
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

static const char *state_name(void)
{
	if (!plugged) return "off";
	if (holding_reset) return "reset";
	if (halted) return "halted";
	if (avr->state == cpu_Sleeping) return "sleeping";
	if (avr->state == cpu_Running) return "running";
	return "stopped";
}

/* ------------------------------------------------------------------ handlers */
static void cmd_status(struct jobj *o, struct sbuf *r)
{
	uint64_t t = now_ns();
	int64_t lag = plugged && !opt_fast ? (int64_t)wall_cycles(t) - (int64_t)avr->cycle : 0;
	sb_add(r, "{\"ok\": true, \"cycle\": %llu, \"sim_us\": %.3f, \"wall_us\": %.3f, "
		  "\"lag_us\": %.3f, \"max_lag_us\": %.3f, \"rebases\": %lu, \"port\": ",
	       (unsigned long long)avr->cycle, (double)avr->cycle / CYC_PER_US,
	       (double)(t - start_ns) / 1000.0, (double)lag / CYC_PER_US,
	       (double)max_lag_cycles / CYC_PER_US, rebase_count);
	sb_json_str(r, plugged ? pty_name : "");
	sb_add(r, ", \"plugged\": %s, \"host_open\": %s, \"state\": \"%s\", \"id\": ",
	       plugged ? "true" : "false", slave_open ? "true" : "false", state_name());
	if (opt_id >= 0) sb_add(r, "%d", opt_id); else sb_add(r, "null");
	sb_add(r, ", \"baud\": %u, \"fixture\": \"%s\", \"usb_bridge\": \"%s\", \"fast\": %s, "
		  "\"reset_on_open\": %s, \"resets\": %lu, \"opens\": %lu, "
		  "\"bytes_to_host\": %lu, \"bytes_from_host\": %lu, \"bytes_discarded\": %lu, \"pty_writes\": %lu, "
		  "\"faults\": {\"drop\": %g, \"insert\": %g, \"flip\": %g, \"dropped\": %lu, "
		  "\"inserted\": %lu, \"flipped\": %lu}, \"pulses_active\": %s, "
		  "\"pulses_done\": {\"2\": %lu, \"3\": %lu}, \"temperature_c\": %g, \"pc\": %u, "
		  "\"last_host_byte_us\": %.3f, \"lost\": {\"to_board\": %lu, \"to_host\": %lu}, "
		  "\"host_rx_stalls\": %lu, \"host_rx_queued\": %u, \"bridge_full_releases\": %lu, "
		  "\"runahead_jumps\": %lu, \"runahead_jump_us\": %.3f, \"baud_mismatch_bytes\": %lu}",
	       opt_baud, fixture_names[opt_fixture], opt_16u2 ? "16u2" : "none",
	       opt_fast ? "true" : "false", opt_reset_on_open ? "true" : "false",
	       reset_count, open_count, bytes_to_host, bytes_from_host, bytes_discarded, pty_writes,
	       fault_drop, fault_insert, fault_flip, faults_dropped, faults_inserted,
	       faults_flipped, pulses_running() ? "true" : "false",
	       gen[0].done, gen[1].done, temperature_c, (unsigned)avr->pc,
	       (double)last_host_byte_t / CYC_PER_US, lost_to_board, lost_to_host,
	       host_rx_stalls, host_rx_queued(), bridge_full_releases, runahead_jumps,
	       (double)runahead_jump_cycles / CYC_PER_US, baud_mismatch_bytes);
}

static void cmd_set_analog(struct jobj *o, struct sbuf *r)
{
	double ch, mv;
	if (!get_num(o, "channel", &ch) || !get_num(o, "mv", &mv) || ch < 0 || ch > 7 || mv < 0 || mv > 5500) {
		sb_add(r, "{\"ok\": false, \"error\": \"set_analog needs channel 0..7 and mv 0..5500\"}");
		return;
	}
	analog_mv[(int)ch] = (int)lround(mv);
	update_analog();
	sb_add(r, "{\"ok\": true, \"r2r_override\": %s}",
	       (opt_fixture == FIX_R2R && ch < 6) ? "true" : "false");
}

static void cmd_set_temperature(struct jobj *o, struct sbuf *r)
{
	double x;
	if (!get_num(o, "celsius", &x) || x < -60 || x > 150) {
		sb_add(r, "{\"ok\": false, \"error\": \"set_temperature needs celsius -60..150\"}");
		return;
	}
	temperature_c = x;
	update_analog();
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
	drive_level[p] = lv->type == J_NULL ? -1 : (lv->num != 0);
	apply_circuit();
	sb_add(r, "{\"ok\": true, \"output\": %s}", is_out(p) ? "true" : "false");
}

static void cmd_pin(struct jobj *o, struct sbuf *r)
{
	int p = get_pin(o, "pin");
	if (p < 0) { sb_add(r, "{\"ok\": false, \"error\": \"bad pin\"}"); return; }
	sb_add(r, "{\"ok\": true, \"pin\": %d, \"ddr\": %d, \"port\": %d, \"level\": %d",
	       p, is_out(p), port_bit(p), pin_level(p));
	if (p >= 14) {
		int ch = p - 14;
		sb_add(r, ", \"mv\": %d", adc_sent[ch]);
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
	if (!plugged || is_out(p) || loop_partner(p) >= 0) {
		sb_add(r, "{\"ok\": false, \"error\": \"pin is not a free input (output, jumpered or unplugged)\"}");
		return;
	}
	start_pulses(p, (unsigned long)cnt, (uint64_t)llround(hi * CYC_PER_US),
		     (uint64_t)llround(lo * CYC_PER_US));
	sb_add(r, "{\"ok\": true, \"done_before\": %lu}", gen[p - 2].done);
}

static void sb_ring(struct sbuf *r, const double *values, unsigned next, unsigned count)
{
	for (unsigned i = 0; i < count; i++) {
		unsigned idx = (next + NEDGE - count + i) % NEDGE;
		sb_add(r, "%s%.3f", i ? ", " : "", values[idx]);
	}
}

static void cmd_pulse_stats(struct jobj *o, struct sbuf *r)
{
	int p = get_pin(o, "pin");
	if (p < 0) { sb_add(r, "{\"ok\": false, \"error\": \"bad pin\"}"); return; }
	struct capture *c = &cap[p];
	sb_add(r, "{\"ok\": true, \"pin\": %d, \"count\": %lu, \"falls\": %lu, \"level\": %d, "
		  "\"highs\": %lu, \"periods\": %lu, \"high_us\": [",
	       p, c->rises, c->falls, c->level, c->highs, c->periods);
	sb_ring(r, c->high_us, c->hi_next, c->nh);
	sb_add(r, "], \"rise_us\": [");
	sb_ring(r, c->rise_us, c->hi_next, c->nh);
	if (c->have_edge)
		sb_add(r, "], \"last_edge_us\": %.3f", (double)c->edge_t / CYC_PER_US);
	else
		sb_add(r, "], \"last_edge_us\": null");
	sb_add(r, ", \"period_us\": [");
	sb_ring(r, c->period_us, c->pe_next, c->np);
	sb_add(r, "]}");
}

static void cmd_clear_pulse_stats(struct jobj *o, struct sbuf *r)
{
	int p = get_pin(o, "pin");
	if (p < 0) { sb_add(r, "{\"ok\": false, \"error\": \"bad pin\"}"); return; }
	struct capture *c = &cap[p];
	int lvl = c->level;
	memset(c, 0, sizeof(*c));
	c->level = lvl;
	sb_add(r, "{\"ok\": true}");
}

static void cmd_set_faults(struct jobj *o, struct sbuf *r)
{
	double v;
	if (get_num(o, "drop", &v)) fault_drop = v;
	if (get_num(o, "insert", &v)) fault_insert = v;
	if (get_num(o, "flip", &v)) fault_flip = v;
	if (get_num(o, "seed", &v)) { rng_state = (uint64_t)v * 0x9E3779B97F4A7C15ULL + 1; }
	sb_add(r, "{\"ok\": true, \"drop\": %g, \"insert\": %g, \"flip\": %g}", fault_drop, fault_insert, fault_flip);
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
	sb_json_str(r, pty_name);
	sb_add(r, "}");
}

static void cmd_reset(struct jobj *o, struct sbuf *r)
{
	if (!plugged) { sb_add(r, "{\"ok\": false, \"error\": \"unplugged\"}"); return; }
	holding_reset = 0;
	power_on_reset();
	sb_add(r, "{\"ok\": true}");
}

static void cmd_firmware_cycles(struct jobj *o, struct sbuf *r)
{
	sb_add(r, "{\"ok\": true, \"samples\": [");
	for (unsigned i = 0; i < fw_nsamples; i++) {
		unsigned idx = (fw_next + NSAMPLES - fw_nsamples + i) % NSAMPLES;
		sb_add(r, "%s%llu", i ? ", " : "", (unsigned long long)fw_samples[idx]);
	}
	sb_add(r, "], \"last\": ");
	if (fw_nsamples) sb_add(r, "%llu", (unsigned long long)fw_last); else sb_add(r, "null");
	sb_add(r, ", \"cycles_per_us\": %llu}", CYC_PER_US);
	if (jget(o, "clear")) fw_nsamples = 0;
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
		memcpy(buf, i2c_ee.ee + (int)off, (size_t)len);
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
