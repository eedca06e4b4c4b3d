/*
 * firmware_cycles.c - exact firmware cycle counts on simavr, without a host.
 *
 * The virtual Uno paces simavr to the wall clock and talks to a Python host
 * through a pty, so on a loaded machine its pipelined figures measure the
 * host.  This drives the same firmware ELF directly: the UART input is kept
 * fed (never more than WINDOW requests in flight, so the receive FIFO never
 * overflows), every cycle is counted, and the cycles the AVR spends asleep
 * are told apart from the rest.  Deterministic: the same ELF gives the same
 * numbers on any machine.
 *
 *   firmware_cycles ELF writes N [WINDOW]   pipelined GPIO WRITE to D13
 *   firmware_cycles ELF pwm N WIDTH_US      soft PWM D2-D7 at WIDTH_US, N pipelined
 *                                           writes meanwhile (0: link idle, 200 ms)
 *   firmware_cycles ELF profile N           as writes, plus the cycles spent at each
 *                                           program address ("profile": [[byte address,
 *                                           cycles], ...], interrupt entry counted at
 *                                           the interrupted instruction, sleep apart)
 *   firmware_cycles ELF seq N               one request at a time (READ ID, then GPIO
 *                                           WRITE): cycles from reading the request's
 *                                           last byte from UDR0 to writing the first
 *                                           reply byte to UDR0 (the virtual Uno's
 *                                           firmware_cycles), median and minimum
 *
 * Prints one JSON object.  Built by benchmarks/firmware_cycles.py.
 */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "avr_ioport.h"
#include "avr_uart.h"
#include "sim_avr.h"
#include "sim_elf.h"

static avr_t *avr;
static avr_irq_t *uart_in;
static int xoff;
static unsigned long reply_bytes;
static int measuring;

static void send(const uint8_t *b, int n);

/* profile mode: cycles per program word while measuring */
static uint64_t *profile;

/* seq mode: UDR0 reads are watched (the UART module's own read handler is
 * wrapped, as the virtual Uno does) */
static unsigned long udr_reads; /* bytes the firmware took from UDR0 */
static int seq_armed;         /* the request's last byte has been injected */
static uint64_t seq_start;    /* cycle of its UDR0 read, 0 = not yet */
static uint64_t seq_first;    /* cycle of the first reply byte's UDR0 write */
static avr_io_read_t udr_read;
static void *udr_read_param;

static uint8_t on_udr_read(struct avr_t *a, avr_io_addr_t addr, void *param)
{
    uint8_t v = udr_read(a, addr, udr_read_param);
    (void)param;
    udr_reads++;
    if (seq_armed && !seq_start)
        seq_start = a->cycle;
    return v;
}

static void on_out(avr_irq_t *irq, uint32_t v, void *p)
{
    (void)irq, (void)v, (void)p;
    if (seq_start && !seq_first)
        seq_first = avr->cycle;
    reply_bytes++;
}

static int cmp_u64(const void *a, const void *b)
{
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return x < y ? -1 : x > y;
}

/* One request at a time, the last byte injected alone (after the others were
 * read), a varying pause before each so the timer tick lands anywhere. */
static void seq_measure(const uint8_t *rq, int len, unsigned long n, uint64_t *out)
{
    for (unsigned long k = 0; k < n; k++) {
        uint64_t until = avr->cycle + 16u * (20u + (k * 37u) % 150u);
        while (avr->cycle < until)
            avr_run(avr);
        reply_bytes = 0;
        unsigned long before = udr_reads;
        send(rq, len - 1);
        while (udr_reads < before + (unsigned long)(len - 1)) /* the others taken */
            avr_run(avr);
        seq_start = seq_first = 0;
        seq_armed = 1;
        send(rq + len - 1, 1);
        while (reply_bytes < 5)
            avr_run(avr);
        seq_armed = 0;
        out[k] = seq_first - seq_start;
    }
    qsort(out, n, sizeof *out, cmp_u64);
}
static void on_xon(avr_irq_t *irq, uint32_t v, void *p) { (void)irq, (void)v, (void)p, xoff = 0; }
static void on_xoff(avr_irq_t *irq, uint32_t v, void *p) { (void)irq, (void)v, (void)p, xoff = 1; }

/* pulse widths on D2-D7 while measuring */
static uint64_t rise_at[8];
static int risen[8];
static double wmin[8], wmax[8], wsum[8];
static unsigned long wcount[8];

static void on_portd(avr_irq_t *irq, uint32_t v, void *p)
{
    int bit = (int)(intptr_t)p;
    (void)irq;
    if (v) {
        rise_at[bit] = avr->cycle;
        risen[bit] = 1;
    } else if (risen[bit] && measuring) {
        double w = (double)(avr->cycle - rise_at[bit]) / 16.0;
        if (!wcount[bit] || w < wmin[bit])
            wmin[bit] = w;
        if (!wcount[bit] || w > wmax[bit])
            wmax[bit] = w;
        wsum[bit] += w;
        wcount[bit]++;
    }
}

static void send(const uint8_t *b, int n)
{
    for (int i = 0; i < n; i++) {
        while (xoff)
            avr_run(avr);
        avr_raise_irq(uart_in, b[i]);
    }
}

static void frame(uint8_t *f, int n) /* n bytes before the checksum */
{
    uint8_t cs = 0;
    for (int i = 0; i < n; i++)
        cs ^= f[i];
    f[n] = cs;
}

int main(int argc, char **argv)
{
    elf_firmware_t fw;
    uint8_t req[2][5] = {{2, 3, 13, 0, 0}, {2, 3, 13, 1, 0}};
    uint8_t cfg[5] = {2, 1, 13, 1, 0};
    unsigned long expect, n, sent = 0, warm = 200;
    int window = 24, pwm = 0;
    uint64_t start, asleep = 0;

    if (argc < 4 || (strcmp(argv[2], "writes") && strcmp(argv[2], "pwm") && strcmp(argv[2], "seq") &&
                      strcmp(argv[2], "profile"))) {
        fprintf(stderr, "usage: %s ELF writes|profile N [WINDOW] | ELF pwm N WIDTH_US | ELF seq N\n",
                argv[0]);
        return 2;
    }
    n = strtoul(argv[3], 0, 0);
    if (!strcmp(argv[2], "profile"))
        profile = calloc(32768 / 2, sizeof *profile);
    if (!strcmp(argv[2], "pwm"))
        pwm = argc > 4 ? atoi(argv[4]) : 1500;
    else if (argc > 4)
        window = atoi(argv[4]);
    memset(&fw, 0, sizeof fw);
    if (elf_read_firmware(argv[1], &fw)) {
        fprintf(stderr, "cannot read %s\n", argv[1]);
        return 1;
    }
    avr = avr_make_mcu_by_name("atmega328p");
    avr_init(avr);
    avr_load_firmware(avr, &fw);
    avr->frequency = 16000000;
    avr->log = 0;
    uint32_t flags = 0;
    avr_ioctl(avr, AVR_IOCTL_UART_GET_FLAGS('0'), &flags);
    flags &= ~AVR_UART_FLAG_STDIO;
    avr_ioctl(avr, AVR_IOCTL_UART_SET_FLAGS('0'), &flags);
    uart_in = avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_INPUT);
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUTPUT), on_out, 0);
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUT_XON), on_xon, 0);
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUT_XOFF), on_xoff, 0);
    for (int b = 2; b < 8; b++)
        avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_IOPORT_GETIRQ('D'), b), on_portd, (void *)(intptr_t)b);
    for (int k = 0; k < 2; k++)
        frame(req[k], 4);
    frame(cfg, 4);

    while (avr->cycle < 16000) /* boot: 1 ms */
        avr_run(avr);
    send(cfg, 5);
    expect = 5;
    if (pwm)
        for (int pin = 2; pin < 8; pin++) {
            uint8_t c[6] = {5, 1, (uint8_t)pin, (uint8_t)(pwm >> 8), (uint8_t)pwm, 0};
            frame(c, 5);
            send(c, 6);
            expect += 6;
        }
    while (reply_bytes < expect && avr->cycle < 16000000)
        avr_run(avr);
    if (reply_bytes < expect) {
        fprintf(stderr, "no reply to the set-up requests\n");
        return 1;
    }
    reply_bytes = 0;
    if (!strcmp(argv[2], "seq")) {
        static const uint8_t read_id[3] = {1, 2, 3};
        uint64_t *c = calloc(n, sizeof *c);
        avr_io_addr_t udr = AVR_DATA_TO_IO(0xC6);
        udr_read = avr->io[udr].r.c;
        udr_read_param = avr->io[udr].r.param;
        avr->io[udr].r.c = on_udr_read;
        printf("{\"elf\": \"%s\", \"mode\": \"seq\", \"n\": %lu", argv[1], n);
        seq_measure(read_id, 3, n, c);
        printf(", \"read_id_cycles_median\": %lu, \"read_id_cycles_min\": %lu", (unsigned long)c[n / 2],
               (unsigned long)c[0]);
        seq_measure(req[1], 5, n, c);
        printf(", \"gpio_write_cycles_median\": %lu, \"gpio_write_cycles_min\": %lu}\n",
               (unsigned long)c[n / 2], (unsigned long)c[0]);
        free(c);
        return 0;
    }
    if (pwm && !n) { /* link idle: 10 frames */
        measuring = 1;
        start = avr->cycle;
        while (avr->cycle < start + 16000000ull / 5)
            avr_run(avr);
    } else {
        start = 0;
        for (;;) {
            unsigned long done = reply_bytes / 5;
            if (done >= warm && !measuring) {
                measuring = 1;
                start = avr->cycle;
            }
            if (done >= warm + n)
                break;
            while (!xoff && sent / 5 < done + (unsigned long)window && sent / 5 < warm + n) {
                avr_raise_irq(uart_in, req[(sent / 5) & 1][sent % 5]);
                sent++;
            }
            int sleeping = avr->state == cpu_Sleeping;
            uint64_t c0 = avr->cycle;
            avr_flashaddr_t pc = avr->pc;
            avr_run(avr);
            if (measuring && sleeping)
                asleep += avr->cycle - c0;
            else if (measuring && profile && pc < 32768)
                profile[pc / 2] += avr->cycle - c0;
            if (avr->state == cpu_Done || avr->state == cpu_Crashed) {
                fprintf(stderr, "the AVR stopped\n");
                return 1;
            }
        }
    }
    uint64_t total = avr->cycle - start;
    printf("{\"elf\": \"%s\", \"mode\": \"%s\", \"n\": %lu", argv[1], argv[2], n);
    if (n)
        printf(", \"window\": %d, \"cycles_per_command\": %.1f, \"awake_cycles_per_command\": %.1f, "
               "\"commands_per_s\": %.0f",
               window, (double)total / n, (double)(total - asleep) / n, n * 16e6 / (double)total);
    if (pwm) {
        double lo = 1e9, hi = 0, sum = 0;
        unsigned long count = 0;
        for (int b = 2; b < 8; b++)
            if (wcount[b]) {
                lo = wmin[b] < lo ? wmin[b] : lo;
                hi = wmax[b] > hi ? wmax[b] : hi;
                sum += wsum[b];
                count += wcount[b];
            }
        printf(", \"pwm_us\": %d, \"pulses\": %lu, \"width_min_us\": %.3f, \"width_max_us\": %.3f, "
               "\"width_mean_us\": %.3f",
               pwm, count, count ? lo : 0.0, hi, count ? sum / count : 0.0);
    }
    if (profile) {
        const char *sep = "";
        printf(", \"profile\": [");
        for (unsigned w = 0; w < 32768 / 2; w++)
            if (profile[w]) {
                printf("%s[%u, %llu]", sep, w * 2, (unsigned long long)profile[w]);
                sep = ", ";
            }
        printf("]");
    }
    printf("}\n");
    return 0;
}
