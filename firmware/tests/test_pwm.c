/*
 * test_pwm.c - host tests of PWM: pulse outputs and duty-cycle PWM (pwm.c, duty.c).
 * Part of `make -C firmware test` (see host_check.h).
 */
#include "host_check.h"

/* ------------------------------------------------------------ PWM */
void test_pwm(void)
{
    int t;
    board();
    CHECK(B(5, 1, 9, 0x05, 0xDC), B(5, 1, 9, 0x05, 0xDC));
    EXPECT(fake_servo_us[0] == 1500);
    CHECK(B(5, 2, 9, 0x05, 0xDD), B(5, 2, 9, 0x05, 0xDD)); /* 1 us resolution */
    EXPECT(fake_servo_us[0] == 1501);
    CHECK(B(5, 2, 9, 0, 0), B(5, 2, 9, 0, 0));
    EXPECT(fake_servo_us[0] == 0);
    CHECK(B(5, 2, 10, 0x05, 0xDC), B(0x85, 2, AIO_ERR_PIN_NOT_CONFIGURED));
    CHECK(B(5, 1, 10, 0, 0), B(5, 1, 10, 0, 0));
    CHECK(B(5, 1, 8, 0x05, 0xDC), B(0x85, 1, AIO_ERR_PIN_NOT_CAPABLE));
    CHECK(B(5, 1, 9, 0x01, 0xF3), B(0x85, 1, AIO_ERR_VALUE_OUT_OF_RANGE)); /* 499 */
    CHECK(B(5, 1, 9, 0x09, 0xC5), B(0x85, 1, AIO_ERR_VALUE_OUT_OF_RANGE)); /* 2501 */
    CHECK(B(5, 1, 4, 0x01, 0xF3), B(0x85, 1, AIO_ERR_VALUE_OUT_OF_RANGE)); /* soft: 499 */
    CHECK(B(2, 1, 4, 1), B(2, 1, 4, 1));
    CHECK(B(5, 1, 4, 0x05, 0xDC), B(0x85, 1, AIO_ERR_PIN_BUSY));
    CHECK(B(2, 4, 4), B(2, 4, 4));
    CHECK(B(5, 1, 4, 0x05, 0xDC), B(5, 1, 4, 0x05, 0xDC)); /* 1500 us */
    /* software PWM: high for 15 ticks every 200 */
    fake_advance(400 - (fake_ticks % 200) - 1);
    {
        int high = 0, starts = 0;
        uint8_t prev = 0;
        for (t = 0; t < 400; t++) {
            fake_advance(1);
            uint8_t now = fake_softpwm_port >> 4 & 1u;
            high += now;
            starts += now && !prev;
            prev = now;
        }
        EXPECT(high == 30 && starts == 2);
        if (high != 30 || starts != 2)
            printf("  soft PWM: high %d starts %d\n", high, starts);
    }
    /* exact to the alarm count: 1500 us = 3000 counts of 0.5 us */
    EXPECT(fake_softpwm_width[4] == 1500u * 2u);
    /* 1 us steps; a new width takes effect at the next frame */
    CHECK(B(5, 2, 4, 0x05, 0xDD), B(5, 2, 4, 0x05, 0xDD)); /* 1501 */
    fake_advance(400);
    EXPECT(fake_softpwm_width[4] == 1501u * 2u);
    CHECK(B(5, 2, 4, 0x07, 0xD0), B(5, 2, 4, 0x07, 0xD0));
    fake_advance(200);
    {
        int high = 0;
        for (t = 0; t < 200; t++) {
            fake_advance(1);
            high += fake_softpwm_port >> 4 & 1u;
        }
        EXPECT(high == 20);
    }
    EXPECT(fake_softpwm_width[4] == 2000u * 2u);
    /* six pins: distinct, equal and 1 us apart widths each exact; frames 20 ms apart */
    {
        static const uint16_t widths[8] = {0, 0, 1000, 1001, 2000, 1500, 1500, 1999};
        uint8_t pin;
        uint32_t rises, before[8];
        for (pin = 2; pin < 8; pin++) {
            if (pin != 4) {
                uint8_t cfg[] = {5, 1, pin, (uint8_t)(widths[pin] >> 8), (uint8_t)widths[pin]};
                check(__FILE__, __LINE__, cfg, sizeof cfg, cfg, sizeof cfg);
            }
        }
        CHECK(B(5, 2, 4, 0x07, 0xD0), B(5, 2, 4, 0x07, 0xD0));
        fake_advance(400);
        memcpy(before, fake_softpwm_rises, sizeof before);
        fake_advance(1000); /* 100 ms: 5 frames */
        for (pin = 2; pin < 8; pin++) {
            EXPECT(fake_softpwm_width[pin] == widths[pin] * 2u);
            EXPECT(fake_softpwm_rises[pin] - before[pin] == 5);
        }
        /* releasing a pin mid-pulse takes it low at once, for good */
        fake_advance(200 - (uint32_t)(fake_fine_now / 200u) % 200u + 5u); /* 0.5 ms into a frame */
        EXPECT(fake_softpwm_port >> 7 & 1u);
        CHECK(B(2, 4, 7), B(2, 4, 7));
        EXPECT(!(fake_softpwm_port >> 7 & 1u));
        rises = fake_softpwm_rises[7];
        fake_advance(400);
        EXPECT(fake_softpwm_rises[7] == rises && fake_softpwm_rises[2] > rises);
        /* width 0 stops that pin's pulses; the last pin stopped stops the alarm */
        for (pin = 2; pin < 7; pin++) {
            uint8_t set0[] = {5, 2, pin, 0, 0};
            check(__FILE__, __LINE__, set0, sizeof set0, set0, sizeof set0);
        }
        fake_advance(400);
        rises = fake_softpwm_rises[2];
        fake_advance(400);
        EXPECT(fake_softpwm_rises[2] == rises && (fake_softpwm_port & 0xFCu) == 0);
        /* and a new width starts it again */
        CHECK(B(5, 2, 3, 0x04, 0x4C), B(5, 2, 3, 0x04, 0x4C)); /* 1100 */
        fake_advance(400);
        EXPECT(fake_softpwm_width[3] == 1100u * 2u && fake_softpwm_rises[3] > rises);
    }
    CHECK(B(2, 4, 4), B(2, 4, 4));
    fake_advance(400);
    EXPECT(!(fake_softpwm_port >> 4 & 1u));
}
