/*
 * test_dispatch.c - host tests of Dispatch: every class refuses a descriptor it does not implement alike (dispatch.c).
 * Part of `make -C firmware test` (see host_check.h).
 */
#include "host_check.h"
#include "dispatch.h"
#include "counter.h"
#include "parser.h"

/* Every handler refuses a descriptor it does not implement, the same way, with nothing
 * changed: called past the parser (which filters them) with a valid pin in data[0]. */
void test_unknown_descriptors(void)
{
    static const uint8_t classes[] = {AIO_CT_MISC, AIO_CT_GPIO,    AIO_CT_ANALOG, AIO_CT_I2C,
                                      AIO_CT_PWM,  AIO_CT_COUNTER, AIO_CT_STREAM, AIO_CT_FAILSAFE};
    aio_request_t rq;
    uint8_t frame[64], fixed, n, i;
    int8_t lp;
    int dt, wrong = 0;

    board();
    CHECK(B(6, 1, 2, 1), B(6, 1, 2, 1));                   /* a counter on D2 */
    CHECK(B(5, 1, 9, 0x05, 0xDC), B(5, 1, 9, 0x05, 0xDC)); /* a servo on D9 */
    CHECK(B(8, 1, 0, 50), B(8, 1, 0, 50));                 /* the failsafe armed */
    counter_counts[0] = 5;
    for (i = 0; i < sizeof classes; i++)
        for (dt = 0; dt < 256; dt++) {
            if (parser_lookup(classes[i], (uint8_t)dt, &fixed, &lp))
                continue;
            memset(&rq, 0, sizeof rq);
            rq.ct = classes[i];
            rq.dt = (uint8_t)dt;
            rq.data[0] = 2;
            n = dispatch(&rq, frame);
            if (n != 4 || frame[0] != (classes[i] | AIO_ERROR_FLAG) || frame[1] != dt ||
                frame[2] != AIO_ERR_UNKNOWN_DESCRIPTOR) {
                if (!wrong++)
                    printf("  class 0x%02x descriptor 0x%02x not refused as unknown\n",
                           classes[i], dt);
            }
        }
    EXPECT(wrong == 0);
    EXPECT(counter_counts[0] == 5 && fake_servo_us[0] == 1500);
    CHECK(B(1, 6), B(1, 6, AIO_STATUS_FAILSAFE_ARMED, 0, 0)); /* still armed */
}
