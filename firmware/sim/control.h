/* control.h - the JSON-lines control socket (see control.c). */
#ifndef VIRTUAL_UNO_CONTROL_H
#define VIRTUAL_UNO_CONTROL_H

#include <poll.h>

#define MAX_CLIENTS 16

const char *control_path(void);         /* the control socket's path */
void control_set_path(const char *path); /* --control, before setup_control */

int setup_control(void);
void close_control(void);
int control_pollfds(struct pollfd *pfds, int n);
void service_control(int fd); /* the listening socket or a client is ready */

#endif
