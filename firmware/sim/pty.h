/* pty.h - the port the host opens and the cable (see pty.c). */
#ifndef VIRTUAL_UNO_PTY_H
#define VIRTUAL_UNO_PTY_H

#include <poll.h>
#include <stddef.h>
#include <stdint.h>

extern int master_fd;
extern char pty_name[128];
extern int plugged;             /* cable in: AVR powered, pty exists */
extern int slave_open;          /* host holds the port open */
extern int holding_reset;       /* DTR auto-reset: held in reset until hold_until_ns */
extern uint64_t hold_until_ns;
extern unsigned long open_count;
extern unsigned long host_rx_stalls;  /* times the harness stopped reading the pty (queue full) */
extern unsigned long baud_mismatch_bytes; /* lost because host and UART rates differ */

/* for wire.c: whether these n bytes are lost to a baud-rate mismatch (counts them) */
int baud_mismatch(size_t n);

int open_pty(void);
void do_unplug(void);
int do_replug(void);

/* for pacing.c */
int pty_pollfds(struct pollfd *pfds, int n);
int waiting_for_host_open(void);
void service_pty(short revents);
void pty_housekeeping(uint64_t t);

#endif
