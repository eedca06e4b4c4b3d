/*
 * test_main.c - host tests: parser + dispatcher + class modules with the fake HAL, one
 * file per firmware module (tests/test_<module>.c).  Built with AddressSanitizer and UBSan
 * by `make -C firmware test`.
 */
#include "host_check.h"

int main(void)
{
    test_table();
    test_misc();
    test_low_latency();
    test_board_description();
    test_gpio();
    test_gpio_changes();
    test_transaction();
    test_counter_reports();
    test_analog_watch();
    test_analog();
    test_i2c();
    test_pwm();
    test_counter();
    test_encoder();
    test_spi();
    test_i2cblock();
    test_pulse_in();
    test_sonar();
    test_stream();
    test_failsafe();
    test_stepper();
    test_unknown_descriptors();
    test_framing();
    test_crc_framing();
    test_pipelining();
    test_ring_positions();
    test_random();
    test_vectors();
    printf("%d checks, %d failures\n", checks, failures);
    return failures != 0;
}
