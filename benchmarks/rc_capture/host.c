/*
 * host.c - drive RC-like pulses into PB0 (D8) of a simavr ATmega328P running capture.c or
 * pinchange.c, and compare the widths the AVR measured with the cycles the pin was high.
 * Usage: host ELF WIDTHS_ADDR N_ADDR PULSES (addresses in hex, as avr-nm prints them).
 * Prints one JSON line: pulses sent, captured, worst and mean |board - truth| in us.
 */
#include <stdio.h>
#include <stdlib.h>
#include <simavr/sim_avr.h>
#include <simavr/sim_elf.h>
#include <simavr/avr_ioport.h>

static void run_until(avr_t *avr, avr_cycle_count_t t)
{
	while (avr->cycle < t)
		avr_run(avr);
}

int main(int argc, char **argv)
{
	if (argc != 5)
		return 2;
	elf_firmware_t f = {0};
	if (elf_read_firmware(argv[1], &f))
		return 2;
	avr_t *avr = avr_make_mcu_by_name("atmega328p");
	avr_init(avr);
	avr_load_firmware(avr, &f);
	avr->frequency = 16000000;
	avr_irq_t *pin = avr_io_getirq(avr, AVR_IOCTL_IOPORT_GETIRQ('B'), 0);
	unsigned waddr = strtoul(argv[2], 0, 16) - 0x800000;
	unsigned naddr = strtoul(argv[3], 0, 16) - 0x800000;
	int pulses = atoi(argv[4]);
	if (pulses > 64)
		pulses = 64;
	avr_cycle_count_t want[64];
	srand(1);
	run_until(avr, 16000);
	for (int k = 0; k < pulses; k++) {
		unsigned wcyc = 16000 + (unsigned)(rand() % 16001); /* 1000-2000 us, any phase */
		avr_cycle_count_t rise = avr->cycle;
		avr_raise_irq(pin, 1);
		run_until(avr, rise + wcyc);
		want[k] = avr->cycle - rise; /* the cycles the pin was really high */
		avr_raise_irq(pin, 0);
		run_until(avr, avr->cycle + 16 * 18000);
	}
	unsigned n = avr->data[naddr];
	double worst = 0, sum = 0;
	for (unsigned i = 0; i < n; i++) {
		unsigned w = avr->data[waddr + 2 * i] | avr->data[waddr + 2 * i + 1] << 8;
		double err = w * 0.5 - want[i] / 16.0;
		if (err < 0)
			err = -err;
		sum += err;
		if (err > worst)
			worst = err;
	}
	printf("{\"pulses\": %d, \"captured\": %u, \"error_us_max\": %.4f, \"error_us_mean\": %.4f}\n",
	       pulses, n, worst, n ? sum / n : 0.0);
	return 0;
}
