/* pty.h - the port the host opens and the cable (see pty.c). */
#ifndef VIRTUAL_UNO_PTY_H
#define VIRTUAL_UNO_PTY_H

#include <poll.h>
#include <stddef.h>
#include <stdint.h>

#include "json.h"

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

int pty_fd(void);               /* the pty master, -1 while unplugged */
const char *pty_port(void);     /* the slave's path */
int pty_plugged(void);          /* cable in: AVR powered, pty exists */
int pty_host_open(void);        /* the host holds the port open */
int pty_holding_reset(void);    /* DTR auto-reset: held in reset until pty_hold_until() */
uint64_t pty_hold_until(void);
void pty_release_reset(void);
void pty_status(struct sbuf *r); /* its part of "status": ", key: value..." */

#endif
