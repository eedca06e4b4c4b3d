/* json.h - the flat JSON objects of the control channel: a small reader
 * (one level, numbers, strings, null, booleans) and a growing reply buffer. */
#ifndef VIRTUAL_UNO_JSON_H
#define VIRTUAL_UNO_JSON_H

#include <stddef.h>
#include <stdint.h>

enum jtype { J_NONE, J_NUM, J_STR, J_NULL, J_BOOL };
struct jval { char key[32]; enum jtype type; double num; char str[256]; };
struct jobj { struct jval v[24]; int n; };

int parse_json(const char *s, struct jobj *o);   /* 0, or -1 if not a flat object */
struct jval *jget(struct jobj *o, const char *k);
int get_num(struct jobj *o, const char *k, double *out); /* number or boolean */

struct sbuf { char *d; size_t len, cap; };
void sb_add(struct sbuf *b, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
void sb_json_str(struct sbuf *b, const char *s);
void sb_bytes(struct sbuf *b, const uint8_t *d, int n);

#endif
