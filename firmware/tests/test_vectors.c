/*
 * test_vectors.c - host tests of The shared request -> reply vectors (tests/vectors), as the virtual Uno and FakeBoard run them.
 * Part of `make -C firmware test` (see host_check.h).
 */
#include "host_check.h"
#include "vectors.h"

/* ------------------------------------------------------------ shared vectors */
/* The .vec files of tests/vectors: the same request -> reply vectors the virtual Uno and FakeBoard run. */
void test_vectors(void)
{
    size_t f, i, j;
    for (f = 0; f < sizeof aio_vector_files / sizeof aio_vector_files[0]; f++) {
        const aio_vector_file_t *vf = &aio_vector_files[f];
        board();
        fake_eeprom[0] = (uint8_t)(vf->board_id >> 8);
        fake_eeprom[1] = (uint8_t)vf->board_id;
        for (i = 0; i < vf->count; i++) {
            const aio_vector_step_t *st = &vf->steps[i];
            int ok;
            if (st->drive_pin >= 0) {
                fake_drive((uint8_t)st->drive_pin, st->drive_level);
                continue;
            }
            fake_rx_push(st->request, st->request_len);
            run();
            take();
            ok = outn == st->reply_len;
            for (j = 0; ok && j < outn; j++)
                ok = st->reply[j] < 0 || out[j] == st->reply[j];
            checks++;
            if (!ok) {
                failures++;
                printf("tests/vectors/%s.vec:%u: FAIL\n", vf->name, st->line);
                dump("request", st->request, st->request_len);
                dump("got", out, outn);
            }
        }
    }
}
