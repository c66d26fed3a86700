//! The link: USB CDC (a virtual serial port, `/dev/ttyACM*` on Linux)
//! through the RP2040's USB controller, `usb-device` and `usbd-serial`.
//!
//! The USB device belongs to its interrupt (`USBCTRL_IRQ`, below the step
//! interrupt's priority), which answers the host, moves received bytes
//! into the RX ring and drains the TX ring into the serial port. The main
//! loop sees only the two rings, each behind a short critical section.
//! With no host reading (cable out, port closed), a frame is dropped whole
//! rather than half-sent: the link resends it.

use core::cell::RefCell;
use core::ptr::addr_of_mut;
use core::sync::atomic::{AtomicBool, AtomicU32, Ordering::Relaxed};
use critical_section::Mutex;
use heapless::Deque;
use rp2040_hal::pac::{self, Interrupt, NVIC};
use rp2040_hal::usb::UsbBus;
use usb_device::bus::UsbBusAllocator;
use usb_device::device::{
    StringDescriptors, UsbDevice, UsbDeviceBuilder, UsbDeviceState, UsbVidPid,
};
use usbd_serial::SerialPort;

/// pid.codes' test VID/PID, until the project has its own PID.
const VID_PID: UsbVidPid = UsbVidPid(0x1209, 0x0001);

static RX: Mutex<RefCell<Deque<u8, 2048>>> = Mutex::new(RefCell::new(Deque::new()));
static TX: Mutex<RefCell<Deque<u8, 4096>>> = Mutex::new(RefCell::new(Deque::new()));
/// A frame delimiter arrived since the main loop last read.
pub static FRAME_END: AtomicBool = AtomicBool::new(false);
/// A host has the port open (configured, DTR set).
static HOST: AtomicBool = AtomicBool::new(false);
/// Bytes lost because the RX ring was full.
pub static RX_DROPPED: AtomicU32 = AtomicU32::new(0);
/// Frames not sent: no host, or no room.
pub static TX_DROPPED: AtomicU32 = AtomicU32::new(0);

struct Usb {
    dev: UsbDevice<'static, UsbBus>,
    serial: SerialPort<'static, UsbBus, [u8; 512], [u8; 512]>,
}

static mut BUS: Option<UsbBusAllocator<UsbBus>> = None;
/// Owned by the USB interrupt once set.
static mut USB: Option<Usb> = None;
/// The serial number string (the uid in hex).
static mut SERIAL_NUMBER: [u8; 16] = [b'0'; 16];

/// Starts the USB device. Call once, before unmasking `USBCTRL_IRQ`.
pub fn init(bus: UsbBus, uid: u64) {
    // SAFETY: called once from `main` before the interrupt that uses
    // these statics is unmasked.
    unsafe {
        let sn = &mut *addr_of_mut!(SERIAL_NUMBER);
        for (i, b) in sn.iter_mut().enumerate() {
            let nibble = (uid >> (60 - 4 * i)) as u8 & 0xf;
            *b = b"0123456789abcdef"[nibble as usize];
        }
        let bus: &'static UsbBusAllocator<UsbBus> =
            (*addr_of_mut!(BUS)).insert(UsbBusAllocator::new(bus));
        let serial = SerialPort::new_with_store(bus, [0; 512], [0; 512]);
        let sn: &'static str = core::str::from_utf8(&*addr_of_mut!(SERIAL_NUMBER)).unwrap_or("0");
        let strings = StringDescriptors::default()
            .manufacturer("motet")
            .product("motet node (pico)")
            .serial_number(sn);
        let Ok(builder) = UsbDeviceBuilder::new(bus, VID_PID).strings(&[strings]) else {
            return;
        };
        let dev = builder.device_class(usbd_serial::USB_CLASS_CDC).build();
        *addr_of_mut!(USB) = Some(Usb { dev, serial });
    }
}

/// The USB interrupt's work.
pub fn on_irq() {
    // SAFETY: only this interrupt touches `USB` after `init`.
    let Some(usb) = (unsafe { (*addr_of_mut!(USB)).as_mut() }) else {
        return;
    };
    usb.dev.poll(&mut [&mut usb.serial]);
    let open = usb.dev.state() == UsbDeviceState::Configured && usb.serial.dtr();
    HOST.store(open, Relaxed);
    let mut buf = [0u8; 64];
    while let Ok(n) = usb.serial.read(&mut buf) {
        if n == 0 {
            break;
        }
        critical_section::with(|cs| {
            let mut rx = RX.borrow_ref_mut(cs);
            for &b in &buf[..n] {
                if rx.push_back(b).is_err() {
                    RX_DROPPED.store(RX_DROPPED.load(Relaxed) + 1, Relaxed);
                }
                if b == 0 {
                    FRAME_END.store(true, Relaxed);
                }
            }
        });
    }
    if !open {
        critical_section::with(|cs| TX.borrow_ref_mut(cs).clear());
        return;
    }
    loop {
        let n = critical_section::with(|cs| {
            let tx = TX.borrow_ref(cs);
            let (a, _) = tx.as_slices();
            let n = a.len().min(buf.len());
            buf[..n].copy_from_slice(&a[..n]);
            n
        });
        if n == 0 {
            break;
        }
        let sent = usb.serial.write(&buf[..n]).unwrap_or(0);
        critical_section::with(|cs| {
            let mut tx = TX.borrow_ref_mut(cs);
            for _ in 0..sent {
                tx.pop_front();
            }
        });
        if sent < n {
            break;
        }
    }
    let _ = usb.serial.flush();
}

/// Received bytes into `buf`.
pub fn read(buf: &mut [u8]) -> usize {
    FRAME_END.store(false, Relaxed);
    critical_section::with(|cs| {
        let mut rx = RX.borrow_ref_mut(cs);
        let mut n = 0;
        while n < buf.len() {
            match rx.pop_front() {
                Some(b) => {
                    buf[n] = b;
                    n += 1;
                }
                None => break,
            }
        }
        n
    })
}

/// Queues a whole frame, or drops it (no host, or no room).
pub fn write(bytes: &[u8]) {
    let queued = HOST.load(Relaxed)
        && critical_section::with(|cs| {
            let mut tx = TX.borrow_ref_mut(cs);
            if tx.capacity() - tx.len() < bytes.len() {
                return false;
            }
            for &b in bytes {
                let _ = tx.push_back(b);
            }
            true
        });
    if queued {
        NVIC::pend(Interrupt::USBCTRL_IRQ);
    } else {
        TX_DROPPED.store(TX_DROPPED.load(Relaxed) + 1, Relaxed);
    }
}

/// Whether the TX ring has drained.
pub fn drained() -> bool {
    critical_section::with(|cs| TX.borrow_ref(cs).is_empty())
}

/// Unmasks the USB interrupt (after `init`).
pub fn start() {
    // SAFETY: the handler's state is set (`init`).
    unsafe { NVIC::unmask(pac::Interrupt::USBCTRL_IRQ) };
}
