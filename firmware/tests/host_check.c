/*
 * host_check.c - what every host test file shares: the fake board's set-up, running the
 * application until idle, and the checks that count (see host_check.h).
 */
#include "host_check.h"

int failures, checks;

uint8_t out[FAKE_TX_MAX];
uint32_t outn;

void board(void)
{
    fake_reset();
    app_init();
}

void run(void)
{
    int guard = 0;
    while (app_step())
        if (++guard > 1000000) {
            printf("app_step never goes idle\n");
            exit(1);
        }
}

void take(void)
{
    memcpy(out, fake_tx, fake_tx_len);
    outn = fake_tx_len;
    fake_tx_len = 0;
}

uint8_t xor_of(const uint8_t *p, size_t n)
{
    uint8_t x = 0;
    while (n--)
        x ^= *p++;
    return x;
}

void send_frame(const uint8_t *req, size_t rn)
{
    uint8_t buf[300];
    memcpy(buf, req, rn);
    buf[rn] = xor_of(req, rn);
    fake_rx_push(buf, (uint32_t)rn + 1u);
}

void dump(const char *what, const uint8_t *p, size_t n)
{
    size_t i;
    printf("  %s:", what);
    for (i = 0; i < n; i++)
        printf(" %02x", p[i]);
    printf("\n");
}

/* Sends req (without CS), expects exactly exp (without CS) + CS back. */
void check(const char *file, int line, const uint8_t *req, size_t rn, const uint8_t *exp,
                  size_t en)
{
    uint8_t want[64];
    send_frame(req, rn);
    run();
    take();
    memcpy(want, exp, en);
    want[en] = xor_of(exp, en);
    checks++;
    if (outn != en + 1 || memcmp(out, want, en + 1)) {
        failures++;
        printf("%s:%d: FAIL\n", file, line);
        dump("request", req, rn);
        dump("expected", want, en + 1);
        dump("got", out, outn);
    }
}
