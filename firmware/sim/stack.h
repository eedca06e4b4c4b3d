/* stack.h - stack depth measurement by painting (see stack.c). */
#ifndef VIRTUAL_UNO_STACK_H
#define VIRTUAL_UNO_STACK_H

struct jobj;
struct sbuf;

void cmd_stack_paint(struct jobj *o, struct sbuf *r);
void cmd_stack_low(struct jobj *o, struct sbuf *r);

#endif
