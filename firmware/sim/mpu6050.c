/*
 * mpu6050.c - an MPU-6050-like IMU at I2C address 0x68 on the TWI bus, with the
 * ground truth the tests read.
 *
 * The register map is the MPU-6050's where the library touches it: WHO_AM_I (0x75)
 * reads 0x68, PWR_MGMT_1 (0x6B) resets to 0x40 (asleep: the data registers hold
 * their last values), GYRO_CONFIG (0x1B) and ACCEL_CONFIG (0x1C) choose the ranges
 * (bits 3-4), CONFIG (0x1A) the DLPF (stored only).  The 14 data bytes at 0x3B
 * (accel x y z, temperature, gyro x y z; big-endian int16) follow a known motion as
 * a function of simulated time t (seconds):
 *   accel (g):   x = 0.5 sin(2 pi t), y = 0.25 cos(2 pi t), z = 1.0
 *   temp (C):    25 + 2 sin(2 pi 0.1 t)   (raw = (C - 36.53) * 340)
 *   gyro (dps):  x = 100 sin(2 pi 0.5 t), y = -50, z = 200 cos(2 pi 0.5 t)
 * scaled by the configured ranges (16384 >> fs LSB/g; 131, 65.5, 32.8, 16.4 LSB/dps) and
 * clipped to int16.  A read latches all 14 bytes at the instant the device is
 * addressed for reading (a consistent snapshot, as the part's shadow registers
 * give); a read starting at 0x3B is logged (simulated us and the 14 bytes) in a
 * ring: the oracle (`imu_reads`).  Fault injection: `{"cmd": "imu", "nack": N}`
 * leaves the next N address phases unacknowledged; `"present": false` takes the
 * device off the bus.
 */
#include "harness.h"

#include <math.h>
#include <string.h>

#include "avr_twi.h"
#include "sim_irq.h"

#include "json.h"
#include "mpu6050.h"

#define ADDR 0x68
#define LOG_SIZE 16384

static struct {
	avr_irq_t *irq;
	uint8_t reg[128];
	uint8_t ptr;
	uint8_t selected; /* 8-bit address while addressed, else 0 */
	int index;        /* bytes written since the address */
	int nack;         /* address phases still to leave unacknowledged */
	int present;
	unsigned long long nacked, reads;
} m;

static struct {
	double us;
	uint8_t b[14];
} logbuf[LOG_SIZE];
static unsigned long long logged; /* entries ever logged; the ring holds the last LOG_SIZE */

static const char *irq_names[2] = {"8>mpu6050.out", "32<mpu6050.in"};

void mpu6050_reset(void)
{
	memset(m.reg, 0, sizeof(m.reg));
	m.reg[0x6B] = 0x40; /* asleep */
	m.reg[0x75] = ADDR; /* WHO_AM_I */
	m.ptr = 0;
	m.selected = 0;
}

static void put16(uint8_t *p, double v)
{
	long x = lround(v);
	if (x > 32767) x = 32767;
	if (x < -32768) x = -32768;
	p[0] = (uint8_t)((unsigned long)x >> 8);
	p[1] = (uint8_t)x;
}

/* The data registers now (awake), from the motion and the ranges. */
static void sample_data(double t)
{
	double a_lsb = 16384.0 / (1 << ((m.reg[0x1C] >> 3) & 3));
	static const double gyro_lsb[4] = {131.0, 65.5, 32.8, 16.4}; /* datasheet, LSB per dps */
	double g_lsb = gyro_lsb[(m.reg[0x1B] >> 3) & 3];
	double w = 2 * M_PI;
	double accel[3] = {0.5 * sin(w * t), 0.25 * cos(w * t), 1.0};
	double gyro[3] = {100 * sin(w * 0.5 * t), -50, 200 * cos(w * 0.5 * t)};
	double temp = 25 + 2 * sin(w * 0.1 * t);
	for (int i = 0; i < 3; i++) {
		put16(&m.reg[0x3B + 2 * i], accel[i] * a_lsb);
		put16(&m.reg[0x43 + 2 * i], gyro[i] * g_lsb);
	}
	put16(&m.reg[0x41], (temp - 36.53) * 340.0);
}

static void twi_hook(struct avr_irq_t *irq, uint32_t value, void *param)
{
	avr_twi_msg_irq_t v;
	v.u.v = value;
	if (v.u.twi.msg & TWI_COND_STOP) {
		m.selected = 0;
		m.index = 0;
	}
	if (v.u.twi.msg & TWI_COND_START) {
		m.selected = 0;
		m.index = 0;
		if (m.present && (v.u.twi.addr >> 1) == ADDR) {
			if (m.nack > 0) {
				m.nack--;
				m.nacked++;
				return; /* no acknowledge: the master sees a NACK */
			}
			m.selected = v.u.twi.addr;
			avr_raise_irq(m.irq + TWI_IRQ_INPUT, avr_twi_irq_msg(TWI_COND_ACK, m.selected, 1));
			if (m.selected & 1) { /* addressed to read: latch the snapshot */
				double us = (double)avr->cycle / CYC_PER_US;
				if (!(m.reg[0x6B] & 0x40))
					sample_data(us / 1e6);
				m.reads++;
				if (m.ptr == 0x3B) {
					logbuf[logged % LOG_SIZE].us = us;
					memcpy(logbuf[logged % LOG_SIZE].b, &m.reg[0x3B], 14);
					logged++;
				}
			}
		}
	}
	if (!m.selected)
		return;
	if (v.u.twi.msg & TWI_COND_WRITE) {
		avr_raise_irq(m.irq + TWI_IRQ_INPUT, avr_twi_irq_msg(TWI_COND_ACK, m.selected, 1));
		if (m.index++ == 0) {
			m.ptr = v.u.twi.data & 0x7F;
		} else {
			if (m.ptr == 0x6B && (v.u.twi.data & 0x80)) /* DEVICE_RESET */
				mpu6050_reset();
			else if (m.ptr != 0x75 && (m.ptr < 0x3B || m.ptr > 0x48))
				m.reg[m.ptr] = v.u.twi.data;
			m.ptr = (m.ptr + 1) & 0x7F;
		}
	}
	if (v.u.twi.msg & TWI_COND_READ) {
		uint8_t data = m.reg[m.ptr];
		m.ptr = (m.ptr + 1) & 0x7F;
		avr_raise_irq(m.irq + TWI_IRQ_INPUT, avr_twi_irq_msg(TWI_COND_READ, m.selected, data));
	}
}

void mpu6050_attach(void)
{
	m.irq = avr_alloc_irq(&avr->irq_pool, 0, 2, irq_names);
	avr_irq_register_notify(m.irq + TWI_IRQ_OUTPUT, twi_hook, NULL);
	avr_connect_irq(m.irq + TWI_IRQ_INPUT, avr_io_getirq(avr, AVR_IOCTL_TWI_GETIRQ(0), TWI_IRQ_INPUT));
	avr_connect_irq(avr_io_getirq(avr, AVR_IOCTL_TWI_GETIRQ(0), TWI_IRQ_OUTPUT), m.irq + TWI_IRQ_OUTPUT);
	m.present = 1;
	mpu6050_reset();
}

/* {"cmd": "imu", ["nack": N], ["present": bool]}: fault injection; replies the
 * device's state (registers of interest, reads, NACKs given, reads logged) */
void cmd_imu(struct jobj *o, struct sbuf *r)
{
	double n;
	if (get_num(o, "nack", &n)) {
		if (n < 0 || n > 1e6) {
			sb_add(r, "{\"ok\": false, \"error\": \"imu needs nack 0..1000000\"}");
			return;
		}
		m.nack = (int)n;
	}
	if (get_num(o, "present", &n))
		m.present = n != 0;
	sb_add(r, "{\"ok\": true, \"address\": %d, \"present\": %s, \"nack_left\": %d, \"nacked\": %llu, "
		  "\"reads\": %llu, \"logged\": %llu, \"pwr_mgmt_1\": %u, \"gyro_config\": %u, "
		  "\"accel_config\": %u, \"config\": %u, \"sim_us\": %.3f}",
	       ADDR, m.present ? "true" : "false", m.nack, m.nacked, m.reads, logged, m.reg[0x6B], m.reg[0x1B],
	       m.reg[0x1C], m.reg[0x1A], (double)avr->cycle / CYC_PER_US);
}

/* {"cmd": "imu_reads", "from": K, ["count": N]}: logged reads K.. (at most 500 a
 * reply, and only those still in the ring): [sim_us, [14 bytes]] each */
void cmd_imu_reads(struct jobj *o, struct sbuf *r)
{
	double from = 0, count = 500;
	get_num(o, "from", &from);
	get_num(o, "count", &count);
	if (from < 0 || count < 0) {
		sb_add(r, "{\"ok\": false, \"error\": \"imu_reads needs from >= 0, count >= 0\"}");
		return;
	}
	unsigned long long k = (unsigned long long)from, oldest = logged > LOG_SIZE ? logged - LOG_SIZE : 0;
	if (k < oldest)
		k = oldest;
	if (count > 500)
		count = 500;
	sb_add(r, "{\"ok\": true, \"logged\": %llu, \"from\": %llu, \"reads\": [", logged, k);
	for (int i = 0; i < (int)count && k < logged; i++, k++) {
		sb_add(r, "%s[%.3f, ", i ? ", " : "", logbuf[k % LOG_SIZE].us);
		sb_bytes(r, logbuf[k % LOG_SIZE].b, 14);
		sb_add(r, "]");
	}
	sb_add(r, "]}");
}
