/*
 * host_check.h - the host tests' shared checks: CHECK (a request and the exact reply),
 * EXPECT (a condition), the fake board's helpers, and every test_* function, one file
 * per firmware module (tests/test_<module>.c, run in order by tests/test_main.c).
 */
#ifndef HOST_CHECK_H
#define HOST_CHECK_H

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "aio_protocol.h"
#include "app.h"
#include "fake_hal.h"
#include "hal.h"

/* Checks run and failed so far (printed by main). */
extern int failures, checks;
/* The bytes the board sent, taken by take(). */
extern uint8_t out[FAKE_TX_MAX];
extern uint32_t outn;

#define B(...) ((const uint8_t[]){__VA_ARGS__}), sizeof((const uint8_t[]){__VA_ARGS__})
#define CHECK(...) check(__FILE__, __LINE__, __VA_ARGS__)
#define EXPECT(cond)                                                         \
    do {                                                                     \
        checks++;                                                            \
        if (!(cond)) {                                                       \
            failures++;                                                      \
            printf("%s:%d: FAIL: %s\n", __FILE__, __LINE__, #cond);          \
        }                                                                    \
    } while (0)

void board(void);     /* a fresh fake board, app initialised */
void run(void);       /* step the application until it is idle */
void take(void);      /* move what the board sent into out/outn */
uint8_t xor_of(const uint8_t *p, size_t n);
void send_frame(const uint8_t *req, size_t rn);  /* req + its XOR check byte */
void dump(const char *what, const uint8_t *p, size_t n);
void check(const char *file, int line, const uint8_t *req, size_t rn, const uint8_t *exp,
           size_t en);

void test_table(void);
void test_misc(void);
void test_low_latency(void);
void test_board_description(void);
void test_gpio(void);
void test_gpio_changes(void);
void test_transaction(void);
void test_counter_reports(void);
void test_analog_watch(void);
void test_analog(void);
void test_i2c(void);
void test_pwm(void);
void test_counter(void);
void test_encoder(void);
void test_spi(void);
void test_i2cblock(void);
void test_pulse_in(void);
void test_sonar(void);
void test_stream(void);
void test_failsafe(void);
void test_stepper(void);
void test_unknown_descriptors(void);
void test_framing(void);
void test_crc_framing(void);
void test_pipelining(void);
void test_ring_positions(void);
void test_random(void);
void test_vectors(void);

#endif
