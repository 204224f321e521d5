from webapp.bus import MemoryBus


async def test_publish_reaches_every_subscriber_of_that_wall_only() -> None:
    bus = MemoryBus(queue_size=8)
    async with bus.subscribe("a") as first, bus.subscribe("a") as second, bus.subscribe("b") as other:
        await bus.publish("a", "hello")
        assert first.queue.get_nowait() == "hello"
        assert second.queue.get_nowait() == "hello"
        assert other.queue.empty()


async def test_slow_subscriber_is_marked_not_blocking() -> None:
    bus = MemoryBus(queue_size=2)
    async with bus.subscribe("a") as slow, bus.subscribe("a") as fast:
        for index in range(3):
            await bus.publish("a", str(index))
            fast.queue.get_nowait()
        assert slow.overflowed.is_set()
        assert slow.queue.qsize() == 2
        assert not fast.overflowed.is_set()


async def test_leaving_unsubscribes() -> None:
    bus = MemoryBus(queue_size=2)
    async with bus.subscribe("a") as subscription:
        pass
    await bus.publish("a", "after")
    assert subscription.queue.empty()
