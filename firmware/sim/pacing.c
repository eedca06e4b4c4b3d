/*
 * pacing.c - one thread runs everything: the AVR in slices, the wall clock,
 * the harness's own event list and the wait on every file descriptor.
 *
 * - One thread.  simavr is not thread safe, so the pty, the control socket and
 *   the simulation are all served from one loop.  The loop runs the AVR in
 *   slices of SLICE_CYCLES, then compares simulated time with the wall clock;
 *   when the simulation is ahead by more than LEAD_MAX_CYCLES it waits in
 *   ppoll() on all file descriptors until the wall clock catches up, so a host
 *   byte or a control request wakes it at once.
 * - Own run function (my_run) instead of avr_callback_run_raw: when the
 *   firmware executes SLEEP, the stock callback would usleep() and then jump
 *   the cycle counter to the next simavr timer whatever happened meanwhile.
 *   Ours waits on the file descriptors and advances the cycle counter only to
 *   the simulated equivalent of the wall time at which it woke up, so host
 *   bytes reach a sleeping firmware immediately and an idle firmware costs no
 *   CPU.  A SLEEP with interrupts disabled halts the core (as on real silicon)
 *   instead of simavr's avr_terminate().
 * - Own event list (not simavr cycle timers) for bridge timing, injection and
 *   the pulse generator, because avr_reset() cancels all simavr cycle timers
 *   (a watchdog reset would silently kill ours).  Events are checked after
 *   every instruction and bound every sleep.
 */
#include "harness.h"

#include <poll.h>
#include <time.h>
#include <unistd.h>

#include "sim_core.h"
#include "sim_time.h"

#include "circuit.h"
#include "control.h"
#include "pacing.h"
#include "pty.h"
#include "quadrature.h"
#include "rcpulse.h"
#include "sonar_model.h"
#include "trace.h"
#include "wire.h"

#define SLICE_CYCLES 128ULL             /* 8 us of simulated time between pacing checks */
#define LEAD_MAX_CYCLES (30ULL * 16)    /* busy link: run at most 30 us ahead of the wall */
#define LEAD_RESUME_CYCLES (15ULL * 16) /* ... then wait until the lead is down to 15 us */
#define ANSWER_LEAD_CYCLES (100ULL * 16) /* answering the host: up to 100 us ahead */
#define ANSWER_RESUME_CYCLES (50ULL * 16) /* ... resuming at 50 us */
#define ANSWER_WINDOW_CYCLES (500ULL * 16) /* "answering": a host byte went in this recently */
#define SPIN_NS 60000ULL                /* spin (not sleep) the last 60 us before output is due */
#ifndef RUNAHEAD_CYCLES
#define RUNAHEAD_CYCLES (2000ULL * 16)  /* idle link: run ahead in slices of up to 2 ms */
#endif
#ifndef RUNAHEAD_SHARE
#define RUNAHEAD_SHARE 32ULL /* ... and at most 1/32 of the wall time the link has been quiet */
#endif
#define LAG_REBASE_CYCLES (50000ULL * 16) /* > 50 ms behind: give up catching up, rebase */

static uint64_t wall_base_ns, cycle_base;
static uint64_t start_ns;
static int64_t max_lag_cycles;
static unsigned long rebase_count;
static int io_ready;
static uint64_t last_io_ns;
static uint64_t quiet_since_ns; /* wall time the link was last busy or a host stimulus came */
static uint64_t last_parent_check_ns;
static unsigned long runahead_jumps;
static uint64_t runahead_jump_cycles;
static uint64_t next_event = UINT64_MAX;
static volatile sig_atomic_t quit_flag; /* SIGINT/SIGTERM, or the parent died */

void pacing_quit(void) { quit_flag = 1; } /* async-signal-safe */

uint64_t now_ns(void)
{
	struct timespec ts;
	clock_gettime(CLOCK_MONOTONIC, &ts);
	return (uint64_t)ts.tv_sec * 1000000000ULL + (uint64_t)ts.tv_nsec;
}

uint64_t wall_cycles(uint64_t ns)
{
	return cycle_base + (ns - wall_base_ns) * CYC_PER_US / 1000ULL;
}

/* The wall time (ns) at which simulated cycle c is due; the past gives wall_base_ns. */
static uint64_t wall_ns_of(uint64_t c)
{
	return c > cycle_base ? wall_base_ns + (c - cycle_base) * 1000ULL / CYC_PER_US : wall_base_ns;
}

/* The bridge's clocks (the host controller's 1 ms USB frames, the 16U2's
 * Timer0) run on their own crystals: their ticks are fixed in wall time, not in
 * the ATmega328P's cycles.  A new time base moves the simulated cycles against
 * the wall by the lead (or lag) it drops, so the bridge clocks' phase, counted
 * in cycles, moves by as much (wire.c: bridge_boundary).  Without it a host
 * arriving after an idle spell met the USB frame at the phase at which the
 * simulation's run-ahead had stopped (10-310 us into a frame after 2 ms
 * slices), not at a random one: 0.81 ms to the next frame on average instead
 * of 0.5. */
static int64_t bridge_clock_offset;

int64_t bridge_clock_phase(void) { return bridge_clock_offset; }

void rebase(void)
{
	uint64_t now = now_ns();
	if (avr && !opt->fast && wall_base_ns)
		bridge_clock_offset += (int64_t)avr->cycle - (int64_t)wall_cycles(now);
	wall_base_ns = now;
	cycle_base = avr ? avr->cycle : 0;
}

/* Idle link: nothing waits to go either way, no pulse train runs.  Then the
 * simulation may run up to RUNAHEAD_CYCLES ahead of the wall clock instead of
 * LEAD_MAX_CYCLES, so a firmware's periodic tick (100 us in the project
 * firmware, a busy loop in Arduino sketches) costs one wait per ~2 ms instead
 * of one per tick.  Whatever the firmware sends meanwhile makes the link busy
 * again and is delivered at its simulated time (the harness waits for the
 * wall clock before handing it over), so board-initiated timing is kept.
 * Not while the UART receiver is off (boot, reset): bytes that would be lost
 * to it on a real board must be lost here too. */
static int link_quiet(int (*wire)(void))
{
	/* and the receiver on: while the firmware boots, a host byte must meet the
	 * receiver-off window in wall time, as on a real board (no run-ahead) */
	return avr && (avr->data[UCSR0B_ADDR] & RXEN0_BIT) && wire() && !pulses_running() &&
	       !quadrature_running() && !rcpulse_running() && !pty_holding_reset();
}

static int link_idle(void)
{
	return link_quiet(wire_idle);
}

/* How far an idle link may run ahead at wall time t: RUNAHEAD_CYCLES, but no
 * more than 1/RUNAHEAD_SHARE of the time since the link was last busy or a
 * host stimulus arrived.  The lead is what the next host stimulus drops from
 * the time base (catch_up_wall), i.e. what the simulated clock gains on the
 * wall: with a fixed 2 ms, back-to-back requests (a gap of ~0.1 ms between a
 * reply and the next request) each gained up to 2 ms, and the simulated clock
 * ran ~8x faster than the wall clock (a servo gave ~430 pulses per wall
 * second).  Bounded by the quiet time, the gain is at most 1/RUNAHEAD_SHARE
 * (3 %) of the wall time however the host spaces its requests, and an idle
 * board (quiet for 64 ms and more) still runs ahead in 2 ms slices. */
static uint64_t idle_lead(uint64_t t)
{
	uint64_t quiet = t > quiet_since_ns ? t - quiet_since_ns : 0;
	uint64_t lead = quiet * CYC_PER_US / 1000ULL / RUNAHEAD_SHARE;
	return lead < RUNAHEAD_CYCLES ? lead : RUNAHEAD_CYCLES;
}

/* The lead allowed now (idle or busy) and where a wait ends (*resume). */
static uint64_t lead_now(uint64_t t, uint64_t *resume);

/* How far a busy link may run ahead, and where a wait for the wall clock ends.
 * While the firmware answers the host (a host byte went into the UART within
 * the last 500 us) the host waits for that answer and rarely sends more, so
 * the simulation may run 100 us ahead: a wait that wakes late (~20-60 us here)
 * still leaves it ahead of the reply's due time.  Otherwise (a stream, events)
 * 30 us: a host byte arriving meanwhile is stamped at most that late. */
static uint64_t busy_lead(uint64_t *resume)
{
	int answering = avr->cycle - wire_last_host_byte() < ANSWER_WINDOW_CYCLES;
	*resume = answering ? ANSWER_RESUME_CYCLES : LEAD_RESUME_CYCLES;
	return answering ? ANSWER_LEAD_CYCLES : LEAD_MAX_CYCLES;
}

static uint64_t lead_now(uint64_t t, uint64_t *resume)
{
	*resume = 0;
	if (link_idle())
		return idle_lead(t);
	quiet_since_ns = t;
	/* A reply whose end is decided and whose bytes only wait for their due
	 * times needs no more simulation: no lead, or the answering lead would be
	 * what the next request drops from the time base (~30 us per request at
	 * 1 Mbaud back to back, 7 % of the wall time). */
	if (link_quiet(wire_only_delivering) && avr->cycle >= output_decided_at())
		return 0;
	return busy_lead(resume);
}

/* A host stimulus (pty bytes, a control command that changes the circuit)
 * arrives at wall time W while the simulation may be running ahead of W.  It
 * cannot be applied in the simulated past, and applying it in the simulated
 * future would delay the firmware's answer by the lead.  Instead the time base
 * moves: "now" in simulated time becomes W.  The simulated clock thus gains
 * at most RUNAHEAD_CYCLES per idle-to-busy transition caused by the host
 * (counted in status: runahead_jumps, runahead_jump_us); latency measured by
 * the host is unaffected. */
void catch_up_wall(void)
{
	if (!avr || opt->fast)
		return;
	uint64_t t = now_ns();
	quiet_since_ns = t; /* the idle run-ahead starts from 0 again */
	uint64_t wc = wall_cycles(t);
	/* With nothing on its way either way no byte's due time moves, so any lead
	 * can go; on a busy link only a lead beyond the busy bound goes (the bytes
	 * on their way keep their due times relative to each other). */
	uint64_t resume;
	if (avr->cycle > wc + (wire_idle() ? CYC_PER_US : busy_lead(&resume))) {
		runahead_jumps++;
		runahead_jump_cycles += avr->cycle - wc;
		trace_event('J', avr->cycle - wc);
		rebase();
	}
}

/* The simulated time at which a host stimulus arriving now takes effect: the
 * wall's "now" (after catch_up_wall), or the simulation's own now while it
 * still runs ahead on a busy link.  Never in the simulated past: a simulation
 * running behind the wall clock meets the stimulus when it gets there. */
uint64_t stimulus_cycle(void)
{
	catch_up_wall();
	if (!avr || opt->fast)
		return avr ? avr->cycle : 0;
	uint64_t wc = wall_cycles(now_ns());
	return wc > avr->cycle ? wc : avr->cycle;
}

/* ------------------------------------------------------------------ events */
void schedule(uint64_t t)
{
	if (t < next_event)
		next_event = t;
}

void recompute_next_event(void)
{
	next_event = UINT64_MAX;
	wire_schedule_events();
	schedule_pulses();
	schedule_quadrature();
	schedule_rcpulse();
	schedule_sonar_model();
}

void run_events(void)
{
	uint64_t now = avr->cycle;
	int progress = 1;
	while (progress) {
		progress = wire_run_events(now);
		progress |= run_pulses(now);
		progress |= run_quadrature(now);
		progress |= run_rcpulse(now);
		progress |= run_sonar_model(now);
	}
	recompute_next_event();
	wire_events_done();
}

/* ------------------------------------------------------------------ run / sleep */
static struct pollfd pfds[MAX_CLIENTS + 2];
static int npfds;

static void build_pollfds(void)
{
	npfds = pty_pollfds(pfds, 0);
	npfds = control_pollfds(pfds, npfds);
}

static int ppoll_ns(uint64_t timeout_ns)
{
	struct timespec ts = {.tv_sec = (time_t)(timeout_ns / 1000000000ULL),
			      .tv_nsec = (long)(timeout_ns % 1000000000ULL)};
	return ppoll(pfds, (nfds_t)npfds, &ts, NULL);
}

/* Wait up to timeout_ns for any descriptor; returns >0 if one is ready.
 * Board->host bytes that wait for their due time bound the wait, and before
 * the end of a reply the host waits for the last SPIN_NS are spent polling
 * without sleeping: a ppoll() that sleeps wakes ~20 us late on this kind of
 * machine (timer slack is already 1 us), which would be added to every
 * reply. */
static int wait_fds(uint64_t timeout_ns)
{
	uint64_t t = now_ns();
	output_service(wall_cycles(t));
	build_pollfds();
	if (waiting_for_host_open() && timeout_ns > 5000000ULL)
		timeout_ns = 5000000ULL; /* look for the host opening the port every 5 ms */
	uint64_t deadline = 0;
	int punctual;
	uint64_t out = output_wake_cycle(&punctual);
	if (out != UINT64_MAX && !opt->fast) {
		uint64_t due = wall_ns_of(out);
		if (due <= t + timeout_ns) { /* output due within this wait */
			timeout_ns = due > t ? due - t : 0;
			if (punctual)
				deadline = t + timeout_ns;
		}
	}
	trace_event('P', timeout_ns);
	int r;
	if (!deadline) {
		r = ppoll_ns(timeout_ns);
	} else {
		r = timeout_ns > SPIN_NS ? ppoll_ns(timeout_ns - SPIN_NS) : 0;
		while (r == 0 && now_ns() < deadline)
			r = ppoll_ns(0);
	}
	trace_event('p', (uint64_t)r);
	return r;
}

/* Called when the firmware sleeps; returns how many cycles to advance. */
static uint64_t sleep_for(uint64_t how_long)
{
	uint64_t target = avr->cycle + 1 + how_long;
	if (next_event < target)
		target = next_event > avr->cycle ? next_event : avr->cycle + 1;
	if (opt->fast) {
		uint64_t t = now_ns();
		if (t - last_io_ns > 200000ULL)
			io_ready = 1;
		return target - avr->cycle;
	}
	for (;;) {
		uint64_t t = now_ns();
		uint64_t wc = wall_cycles(t);
		/* idle link: sleep through the tick in simulated time only, as long as
		 * the lead stays within RUNAHEAD_CYCLES; once it would not, wait until
		 * the wall clock reaches the target (lead back to 0), so waits come in
		 * slices of ~2 ms instead of one per timer tick.  Busy link: sleep on
		 * in simulated time within LEAD_MAX_CYCLES, else wait until the lead
		 * is down to LEAD_RESUME_CYCLES (a wait that wakes late then still
		 * leaves the simulation ahead of the bytes due to the host). */
		uint64_t resume;
		uint64_t lead = lead_now(t, &resume);
		if (wc >= target || target - wc <= lead)
			return target - avr->cycle;
		uint64_t decided = output_decided_at();
		if (decided > avr->cycle) /* sleep only as far as deciding a burst's end, no wait */
			return (decided < target ? decided : target) - avr->cycle;
		uint64_t wait_ns = (target - wc - resume) * 1000ULL / CYC_PER_US;
		int r = wait_fds(wait_ns);
		if (quit_flag)
			r = 1;
		if (r != 0) {
			io_ready = 1;
			wc = wall_cycles(now_ns());
			if (wc <= avr->cycle)
				return 1;
			if (wc > target)
				wc = target;
			return wc - avr->cycle;
		}
		if (waiting_for_host_open()) {
			/* woke from the 5 ms cap: let the main loop look for the host opening the port */
			io_ready = 1;
			wc = wall_cycles(now_ns());
			if (wc <= avr->cycle)
				return 1;
			return (wc < target ? wc : target) - avr->cycle;
		}
	}
}

void my_run(avr_t *a)
{
	avr_flashaddr_t new_pc = a->pc;
	if (a->state == cpu_Running)
		new_pc = avr_run_one(a);
	avr_cycle_count_t sleep = avr_cycle_timer_process(a);
	a->pc = new_pc;
	if (a->state == cpu_Sleeping) {
		if (!a->sreg[S_I]) {
			halted = 1; /* like silicon: asleep forever (until reset) */
			return;
		}
		a->cycle += sleep_for(sleep);
	}
	if ((a->state == cpu_Running || a->state == cpu_Sleeping) && a->interrupt_state) {
		avr_flashaddr_t before = a->pc;
		avr_service_interrupts(a);
		/* a vector entered: the quadrature generators measure their pins' interrupt latency */
		if (a->pc != before && a->pc < 64u * a->vector_size)
			quadrature_vector_taken(a->pc / a->vector_size, a->cycle);
	}
}

/* Handle ready descriptors after a ppoll (wait_fds) or poll with 0 timeout. */
static void service_io(void)
{
	last_io_ns = now_ns();
	for (int i = 0; i < npfds; i++) {
		if (!pfds[i].revents) continue;
		int fd = pfds[i].fd;
		if (fd == pty_fd() && fd >= 0)
			service_pty(pfds[i].revents);
		else
			service_control(fd);
		pfds[i].revents = 0;
	}
	npfds = 0;
	uint64_t t = now_ns();
	if (opt->exit_with_parent && t - last_parent_check_ns > 200000000ULL) {
		/* launcher died without stopping us (SIGKILL): do not linger */
		last_parent_check_ns = t;
		if (getppid() != opt->parent_pid)
			quit_flag = 1;
	}
	pty_housekeeping(t);
	run_events();
}

static void poll_io(uint64_t timeout_ns)
{
	int r = wait_fds(timeout_ns);
	if (r < 0) npfds = 0;
	service_io();
}

void run_paced(void)
{
	last_io_ns = now_ns();
	while (!quit_flag) {
		announce_when_listening();
		if (!pty_plugged() || pty_holding_reset() || halted) {
			uint64_t to = 20000000ULL;
			if (pty_holding_reset()) {
				uint64_t t = now_ns();
				to = pty_hold_until() > t ? pty_hold_until() - t : 0;
			}
			poll_io(to);
			if (!pty_plugged() || pty_holding_reset() || halted)
				rebase(); /* simulated time does not run while off/held */
			continue;
		}
		uint64_t end = avr->cycle + SLICE_CYCLES;
		io_ready = 0;
		while (avr->cycle < end && !io_ready && !halted) {
			avr->run(avr);
			if (avr->cycle >= next_event)
				run_events();
			if (reset_seen) /* e.g. watchdog reset inside simavr */
				after_reset();
			if (avr->state != cpu_Running && avr->state != cpu_Sleeping) {
				halted = 1;
				break;
			}
		}
		if (quit_flag) break;
		update_extint_strict();
		uint64_t t = now_ns();
		if (io_ready) {
			poll_io(0);
			t = now_ns();
		}
		output_service(wall_cycles(t));
		if (opt->fast) {
			if (t - last_io_ns > 200000ULL) poll_io(0);
			continue;
		}
		uint64_t wc = wall_cycles(t);
		uint64_t resume;
		uint64_t lead = lead_now(t, &resume);
		if (avr->cycle > wc + lead && avr->cycle >= output_decided_at()) {
			/* idle: until the lead is 0 (slices of ~2 ms); busy: down to the resume lead */
			poll_io((avr->cycle - wc - resume) * 1000ULL / CYC_PER_US);
		} else {
			int64_t lag = (int64_t)wc - (int64_t)avr->cycle;
			if (lag > max_lag_cycles) max_lag_cycles = lag;
			if (lag > (int64_t)LAG_REBASE_CYCLES) {
				rebase();
				rebase_count++;
				wire_time_base_reset(); /* host bytes stamped at the old wall's now */
			}
			/* computing, not waiting: look for host bytes every 20 us of wall time */
			if (t - last_io_ns > 20000ULL) poll_io(0);
		}
	}
}

/* ------------------------------------------------------------------ status */
void pacing_start(void) { start_ns = now_ns(); }

void pacing_status(struct sbuf *r)
{
	uint64_t t = now_ns();
	int64_t lag = pty_plugged() && !opt->fast ? (int64_t)wall_cycles(t) - (int64_t)avr->cycle : 0;
	sb_add(r, ", \"cycle\": %llu, \"sim_us\": %.3f, \"wall_us\": %.3f, \"lag_us\": %.3f, "
		  "\"max_lag_us\": %.3f, \"rebases\": %lu, \"runahead_jumps\": %lu, "
		  "\"runahead_jump_us\": %.3f",
	       (unsigned long long)avr->cycle, (double)avr->cycle / CYC_PER_US,
	       (double)(t - start_ns) / 1000.0, (double)lag / CYC_PER_US,
	       (double)max_lag_cycles / CYC_PER_US, rebase_count, runahead_jumps,
	       (double)runahead_jump_cycles / CYC_PER_US);
}
