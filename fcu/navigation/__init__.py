"""What the vehicle should do: flight modes, arming, missions and the guidance references."""
