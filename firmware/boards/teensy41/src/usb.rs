//! The link: USB CDC serial (full speed) through `imxrt-usbd`,
//! `usb-device` and `usbd-serial`, served from the USB interrupt. Bytes
//! pass between the interrupt and the main loop through two lock-free
//! rings, so a frame is queued without masking the step interrupt.

use core::ptr::addr_of_mut;
use core::sync::atomic::{AtomicBool, AtomicU32, Ordering::Relaxed};
use heapless::spsc::{Consumer, Producer, Queue};
use imxrt_usbd::{BusAdapter, EndpointMemory, EndpointState, Speed};
use usb_device::bus::UsbBusAllocator;
use usb_device::device::{
    StringDescriptors, UsbDevice, UsbDeviceBuilder, UsbDeviceState, UsbVidPid,
};
use usb_device::LangID;
use usbd_serial::SerialPort;

/// The Teensy's USB serial identity (PJRC's, which the Teensy's udev
/// rules already let users open).
const VID_PID: UsbVidPid = UsbVidPid(0x16C0, 0x0483);

static EP_MEMORY: EndpointMemory<2048> = EndpointMemory::new();
static EP_STATE: EndpointState = EndpointState::max_endpoints();
static mut BUS: Option<UsbBusAllocator<BusAdapter>> = None;

/// What the USB interrupt owns once set.
struct Link {
    device: UsbDevice<'static, BusAdapter>,
    serial: SerialPort<'static, BusAdapter>,
    rx: Producer<'static, u8>,
    tx: Consumer<'static, u8>,
    /// Bytes taken from the ring and not yet accepted by the endpoint.
    out: heapless::Vec<u8, 64>,
    out_pos: usize,
}

static mut LINK: Option<Link> = None;
static mut RX_QUEUE: Queue<u8, 4096> = Queue::new();
static mut TX_QUEUE: Queue<u8, 8192> = Queue::new();

/// A host configured the device (a cable and a driver on the other end).
pub static CONFIGURED: AtomicBool = AtomicBool::new(false);
/// A frame delimiter arrived since the main loop last read the link.
pub static FRAME_END: AtomicBool = AtomicBool::new(false);
/// Bytes lost because the receive ring was full.
pub static RX_DROPPED: AtomicU32 = AtomicU32::new(0);

/// Sets up the USB device and its rings; returns the main loop's halves.
/// Call once, before the USB interrupt is unmasked.
pub fn init(usb: imxrt_usbd::Instances<1>) -> (Consumer<'static, u8>, Producer<'static, u8>) {
    let adapter = BusAdapter::with_speed(usb, &EP_MEMORY, &EP_STATE, Speed::LowFull);
    adapter.set_interrupts(true);
    // SAFETY: called once, before the interrupt that uses these statics
    // is unmasked.
    unsafe {
        let bus: &'static UsbBusAllocator<BusAdapter> =
            (*addr_of_mut!(BUS)).insert(UsbBusAllocator::new(adapter));
        let serial = SerialPort::new(bus);
        let device = UsbDeviceBuilder::new(bus, VID_PID)
            .strings(&[StringDescriptors::new(LangID::EN_US)
                .manufacturer("motet")
                .product("motet node (teensy41)")])
            .unwrap_or_else(|_| cortex_m::peripheral::SCB::sys_reset())
            .device_class(usbd_serial::USB_CLASS_CDC)
            .max_packet_size_0(64)
            .unwrap_or_else(|_| cortex_m::peripheral::SCB::sys_reset())
            .build();
        let (rx_p, rx_c) = (*addr_of_mut!(RX_QUEUE)).split();
        let (tx_p, tx_c) = (*addr_of_mut!(TX_QUEUE)).split();
        *addr_of_mut!(LINK) = Some(Link {
            device,
            serial,
            rx: rx_p,
            tx: tx_c,
            out: heapless::Vec::new(),
            out_pos: 0,
        });
        (rx_c, tx_p)
    }
}

/// The USB interrupt: the device's state machine, received bytes into
/// the receive ring, queued bytes out.
pub fn on_interrupt() {
    // SAFETY: set in `init` before this interrupt was unmasked; only this
    // interrupt uses it afterwards.
    let Some(link) = (unsafe { (*addr_of_mut!(LINK)).as_mut() }) else {
        return;
    };
    link.device.poll(&mut [&mut link.serial]);
    let configured = link.device.state() == UsbDeviceState::Configured;
    CONFIGURED.store(configured, Relaxed);
    if !configured {
        // Nobody to send to: what is queued is dropped, as a cable would.
        while link.tx.dequeue().is_some() {}
        link.out.clear();
        link.out_pos = 0;
        return;
    }
    let mut buf = [0u8; 64];
    while link.rx.capacity() - link.rx.len() >= buf.len() {
        match link.serial.read(&mut buf) {
            Ok(n) if n > 0 => {
                for &b in &buf[..n] {
                    if link.rx.enqueue(b).is_err() {
                        RX_DROPPED.fetch_add(1, Relaxed);
                    }
                    if b == 0 {
                        FRAME_END.store(true, Relaxed);
                    }
                }
            }
            _ => break,
        }
    }
    pump(link);
}

fn pump(link: &mut Link) {
    loop {
        if link.out_pos == link.out.len() {
            link.out.clear();
            link.out_pos = 0;
            while !link.out.is_full() {
                match link.tx.dequeue() {
                    Some(b) => {
                        let _ = link.out.push(b);
                    }
                    None => break,
                }
            }
            if link.out.is_empty() {
                return;
            }
        }
        match link.serial.write(&link.out[link.out_pos..]) {
            Ok(k) if k > 0 => link.out_pos += k,
            // The endpoint is busy: the next interrupt (its transfer done)
            // goes on from here.
            _ => return,
        }
    }
}
