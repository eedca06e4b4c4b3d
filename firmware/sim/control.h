/* control.h - the JSON-lines control socket (see control.c). */
#ifndef VIRTUAL_UNO_CONTROL_H
#define VIRTUAL_UNO_CONTROL_H

#include <poll.h>

#define MAX_CLIENTS 16

extern char ctl_path[600];

int setup_control(void);
void close_control(void);
int control_pollfds(struct pollfd *pfds, int n);
void service_control(int fd); /* the listening socket or a client is ready */

#endif
