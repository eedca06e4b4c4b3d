/* json.c - reader and writer for the control channel's one-line JSON objects. */
#include "harness.h"

#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "json.h"

static const char *skip_ws(const char *s) { while (*s == ' ' || *s == '\t' || *s == '\r' || *s == '\n') s++; return s; }

static const char *parse_str(const char *s, char *out, size_t cap)
{
	size_t n = 0;
	if (*s != '"') return NULL;
	s++;
	while (*s && *s != '"') {
		char c = *s++;
		if (c == '\\' && *s) {
			char e = *s++;
			c = e == 'n' ? '\n' : e == 't' ? '\t' : e;
		}
		if (n + 1 < cap) out[n++] = c;
	}
	if (*s != '"') return NULL;
	out[n] = 0;
	return s + 1;
}

int parse_json(const char *s, struct jobj *o)
{
	o->n = 0;
	s = skip_ws(s);
	if (*s++ != '{') return -1;
	s = skip_ws(s);
	if (*s == '}') return 0;
	for (;;) {
		if (o->n >= 24) return -1;
		struct jval *v = &o->v[o->n];
		memset(v, 0, sizeof(*v));
		s = skip_ws(s);
		s = parse_str(s, v->key, sizeof(v->key));
		if (!s) return -1;
		s = skip_ws(s);
		if (*s++ != ':') return -1;
		s = skip_ws(s);
		if (*s == '"') {
			s = parse_str(s, v->str, sizeof(v->str));
			if (!s) return -1;
			v->type = J_STR;
		} else if (!strncmp(s, "null", 4)) {
			v->type = J_NULL; s += 4;
		} else if (!strncmp(s, "true", 4)) {
			v->type = J_BOOL; v->num = 1; s += 4;
		} else if (!strncmp(s, "false", 5)) {
			v->type = J_BOOL; v->num = 0; s += 5;
		} else {
			char *end;
			v->num = strtod(s, &end);
			if (end == s) return -1;
			v->type = J_NUM; s = end;
		}
		o->n++;
		s = skip_ws(s);
		if (*s == ',') { s++; continue; }
		if (*s == '}') return 0;
		return -1;
	}
}

struct jval *jget(struct jobj *o, const char *k)
{
	for (int i = 0; i < o->n; i++)
		if (!strcmp(o->v[i].key, k))
			return &o->v[i];
	return NULL;
}

int get_num(struct jobj *o, const char *k, double *out)
{
	struct jval *v = jget(o, k);
	if (!v || (v->type != J_NUM && v->type != J_BOOL)) return 0;
	*out = v->num;
	return 1;
}

void sb_add(struct sbuf *b, const char *fmt, ...)
{
	va_list ap;
	for (;;) {
		va_start(ap, fmt);
		int n = vsnprintf(b->d + b->len, b->cap - b->len, fmt, ap);
		va_end(ap);
		if (n >= 0 && (size_t)n < b->cap - b->len) { b->len += (size_t)n; return; }
		b->cap = b->cap * 2 + (size_t)n + 64;
		b->d = realloc(b->d, b->cap);
	}
}

void sb_json_str(struct sbuf *b, const char *s)
{
	sb_add(b, "\"");
	for (; *s; s++) {
		if (*s == '"' || *s == '\\') sb_add(b, "\\%c", *s);
		else if ((unsigned char)*s < 0x20) sb_add(b, "\\u%04x", *s);
		else sb_add(b, "%c", *s);
	}
	sb_add(b, "\"");
}

void sb_bytes(struct sbuf *b, const uint8_t *d, int n)
{
	sb_add(b, "[");
	for (int i = 0; i < n; i++) sb_add(b, "%s%u", i ? "," : "", d[i]);
	sb_add(b, "]");
}
